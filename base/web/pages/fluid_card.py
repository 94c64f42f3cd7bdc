"""What the fluids card of an encounter says, from the stored Assessment and its FluidPlan, in plain words.

- No plan: it names only what the record actually lacks (the weight, the age, the time of injury, a burn chart).
- Formal resuscitation indicated: the rate to run now, the formula and the phase.
- Below the threshold: never a formula rate. Oral fluids and the urine output to watch, and a child's maintenance
  rate where the plan has one (processing/clinical/fluid_advice.py words the recommendation the same way).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from base.web.pages.forms_spec import human
from schemas.clinical_results import Assessment, FluidPhase, FluidPlan

MISSING_INJURY_TIME_PREFIX = "time of injury"
"""How processing/clinical/assessment.py's `missing` line for the time of injury starts (a test keeps it so)."""
FORMULA_ONLY_WARNING_PREFIX = "This plan is a starting point"
"""The warning about running the formula's rate (processing/clinical/fluids.py TITRATE_WARNING): not shown when
formal resuscitation is not indicated, since no formula rate is shown then."""
BURN_CHART = "burn_chart"
PHASES = {FluidPhase.first_8h: "first 8 h", FluidPhase.next_16h: "hours 8–24"}


@dataclass(frozen=True)
class FluidCard:
    value: str
    """The figure in large type: "420 mL/h now", "Oral fluids", "—"."""
    meta: str
    """The line under it."""
    advice: list[str] = field(default_factory=list)
    """Paragraphs under the figures."""
    warnings: list[str] = field(default_factory=list)
    urine: str = ""
    """The urine output target for the hint line, or only its basis where the advice names it ("" with no plan)."""


def _n(x: float, digits: int = 1) -> str:
    text = f"{x:,.{digits}f}"
    return text.rstrip("0").rstrip(".") if "." in text else text


def _and(items: list[str]) -> str:
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def fluid_needs(assessment: Assessment) -> list[str]:
    """What the fluid plan still needs, only what is missing from the record."""
    needs = []
    if assessment.weight_kg is None:
        needs.append("the patient's weight")
    if assessment.age_years is None:
        needs.append("the patient's age (date of birth or an estimate)")
    if any(m.startswith(MISSING_INJURY_TIME_PREFIX) for m in assessment.missing):
        needs.append("the time of injury")
    if not any(ref.kind == BURN_CHART for ref in assessment.inputs):
        needs.append("a burn chart")
    return needs


def _urine(plan: FluidPlan) -> str:
    u = plan.urine_output_target
    return (
        f"urine output {_n(u.ml_per_kg_per_h_low)}–{_n(u.ml_per_kg_per_h_high)} mL/kg/h "
        f"({_n(u.ml_per_h_low, 0)}–{_n(u.ml_per_h_high, 0)} mL/h)"
    )


def fluid_card(assessment: Assessment) -> FluidCard:
    plan = assessment.fluids
    if plan is None:
        needs = fluid_needs(assessment)
        if needs:
            return FluidCard("—", f"No fluid plan yet: record {_and(needs)}.")
        return FluidCard("—", "No fluid plan: it could not be worked out from the record (see the problems below).")
    urine = f"{_urine(plan)}, {plan.urine_output_target.basis}"
    maintenance = plan.maintenance
    if not plan.formal_resuscitation_indicated:
        advice = [
            f"Formal resuscitation is not usually needed below {_n(plan.formal_resuscitation_threshold_percent)} "
            f"%TBSA for this patient (this burn: {_n(plan.tbsa_percent)} %): encourage oral fluids; "
            f"watch {_urine(plan)}."
        ]
        if maintenance is not None:
            advice.append(f"Maintenance fluid for this child: {_n(maintenance.ml_per_h)} mL/h ({maintenance.rule}).")
        warnings = [w for w in plan.warnings if not w.startswith(FORMULA_ONLY_WARNING_PREFIX)]
        value = "Maintenance fluid" if maintenance is not None else "Oral fluids"
        meta = f"formal resuscitation not indicated below {_n(plan.formal_resuscitation_threshold_percent)} %TBSA"
        if maintenance is not None:
            meta += f"; maintenance {_n(maintenance.ml_per_h)} mL/h"
        # The advice names the target already; the hint adds where it comes from.
        return FluidCard(value, meta, advice, warnings, plan.urine_output_target.basis)
    meta = f"{human(plan.formula)} {_n(plan.ml_per_kg_per_percent)} mL/kg/%TBSA, {_n(plan.weight_kg)} kg ({plan.weight_source})"
    if plan.phase == FluidPhase.complete:
        value = "24-hour period over"
    else:
        value = f"{_n(plan.rate_now_ml_per_h, 0)} mL/h now"
        meta += (
            f"; {PHASES.get(plan.phase, plan.phase)}: {_n(plan.remaining_in_phase_ml, 0)} mL left over "
            f"{_n(plan.hours_left_in_phase)} h"
        )
    return FluidCard(value, meta, [plan.statement], list(plan.warnings), urine)
