"""The fluid recommendation: the plan the calculators made, in words that do not change as the clock runs.

The rate to run now changes every minute; it is read from the assessment when the report is made
(processing/report), so the recommendation a clinician accepted stays the same recommendation.
"""

from __future__ import annotations

import datetime as dt

from processing.clinical.decision_inputs import DecisionInputs
from processing.clinical.sources import ABLS_FLUIDS
from schemas.clinical_results import FluidPhase, FluidPlan
from schemas.decision_support import Recommendation, RecommendationCategory

MISSING_PLAN = "fluid plan (needs weight, %TBSA from the burn chart, age and time of injury): no fluid advice"


def _ml(value: float) -> str:
    return f"{value:,.0f} mL"


def _clock(t: dt.datetime) -> str:
    return t.strftime("%Y-%m-%d %H:%M UTC")


def plan_text(plan: FluidPlan) -> tuple[str, list[str]]:
    injury = plan.time_of_injury
    eight, day = injury + dt.timedelta(hours=8), injury + dt.timedelta(hours=24)
    urine = plan.urine_output_target
    target = (
        f"urine output {urine.ml_per_kg_per_h_low:g}-{urine.ml_per_kg_per_h_high:g} mL/kg/h "
        f"({urine.ml_per_h_low:,.0f}-{urine.ml_per_h_high:,.0f} mL/h)"
    )
    if not plan.formal_resuscitation_indicated:
        text = (
            f"Fluids: burn of {plan.tbsa_percent:g} %TBSA, below the {plan.formal_resuscitation_threshold_percent:g} %"
            f" threshold: formal resuscitation is not usually required; oral or maintenance fluids, watch {target}."
        )
    else:
        text = (
            f"Fluids: {plan.multiplier_basis}: {_ml(plan.total_24h_ml)} crystalloid in the 24 h from injury; "
            f"{_ml(plan.first_8h_ml)} by {_clock(eight)}, then {_ml(plan.next_16h_ml)} by {_clock(day)}. "
            f"Titrate hourly to {target}."
        )
    details = [w for w in plan.warnings if "not counted" not in w]
    if plan.maintenance is not None:
        details.append(f"Child: add maintenance fluid {plan.maintenance.ml_per_h:,.1f} mL/h ({plan.maintenance.rule}).")
    return text, details


def recommend(inputs: DecisionInputs) -> tuple[list[Recommendation], list[str]]:
    assessment = inputs.assessment
    plan = assessment.value.fluids if assessment else None
    if plan is None:
        return [], [MISSING_PLAN]
    text, details = plan_text(plan)
    used = [
        assessment.used("weight", f"{plan.weight_kg:g} kg ({plan.weight_source})"),
        assessment.used("%TBSA", f"{plan.tbsa_percent:g} %"),
        assessment.used("time of injury", plan.time_of_injury),
        assessment.used("formula", plan.multiplier_basis),
    ]
    running = plan.formal_resuscitation_indicated and plan.phase is not FluidPhase.complete
    return [
        Recommendation(
            key="fluids.plan",
            category=RecommendationCategory.fluids,
            text=text,
            details=details,
            inputs=used,
            source=ABLS_FLUIDS,
            urgent=running,
        )
    ], []
