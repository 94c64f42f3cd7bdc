"""Pain: paracetamol for every burn, intranasal fentanyl for a child whose pain is not controlled, and IV opioids
for a severe burn (processing/clinical/pain_opioids.py).

Weight-based doses are given only where the source gives them, from the recorded weight and capped at the
source's maximum; with no weight, no dose is shown and the reason is. A recorded allergy to a drug blocks it.
Ibuprofen is not dosed: the sources checked disagree on its age limit and daily maximum (docs/clinical.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import msgspec

from processing.clinical import pain_opioids
from processing.clinical.decision_inputs import ADULT_FROM_YEARS, DecisionInputs
from processing.clinical.pain_allergy import allergy_to
from processing.clinical.sources import NHS_PARACETAMOL_ADULT, RCH_ANALGESIA
from schemas.decision_support import InputUsed, Recommendation, RecommendationCategory

ADULT_FIXED_DOSE_FROM_KG = 50.0
"""The adult fixed dose is for 50 kg and over; under it the source says to check the maximum dose."""
PARACETAMOL_FROM_MONTHS = 3.0
FENTANYL_FROM_YEARS = 1.0


@dataclass(frozen=True)
class WeightDose:
    per_kg: float
    max_dose: float
    unit: str
    max_day_per_kg: float | None = None
    max_day: float | None = None

    def dose(self, weight_kg: float) -> float:
        return min(self.per_kg * weight_kg, self.max_dose)

    def daily(self, weight_kg: float) -> float | None:
        if self.max_day_per_kg is None:
            return None
        return min(self.max_day_per_kg * weight_kg, self.max_day)


PARACETAMOL_CHILD = WeightDose(per_kg=15.0, max_dose=1000.0, unit="mg", max_day_per_kg=60.0, max_day=4000.0)
FENTANYL_IN_CHILD = WeightDose(per_kg=1.5, max_dose=75.0, unit="mcg")


def _paracetamol(inputs: DecisionInputs, weight: float | None, used: list[InputUsed]) -> Recommendation:
    age = inputs.age_years
    source = RCH_ANALGESIA
    blocked = allergy_to(inputs, "paracetamol")
    if blocked is not None:
        text = f"Pain: paracetamol is not advised: allergy recorded to {blocked[0]}. Choose another analgesic."
        used = [*used, blocked[1]]
    elif age is None:
        text = "Pain: paracetamol; no dose shown: the age is not recorded (child and adult doses differ)."
    elif age < PARACETAMOL_FROM_MONTHS / 12:
        text = "Pain: infant under 3 months: paracetamol only on a doctor's advice; no dose shown."
    elif age >= ADULT_FROM_YEARS and weight is not None and weight >= ADULT_FIXED_DOSE_FROM_KG:
        source = NHS_PARACETAMOL_ADULT
        text = "Pain: paracetamol 500 mg to 1 g by mouth, at least 4 hours apart; at most 4 g in 24 hours."
    elif age >= ADULT_FROM_YEARS:
        why = "no weight is recorded" if weight is None else f"the weight is under {ADULT_FIXED_DOSE_FROM_KG:g} kg"
        source = NHS_PARACETAMOL_ADULT
        text = f"Pain: paracetamol; no dose shown: {why}, and the source says to check the maximum dose then."
    elif weight is None:
        text = "Pain: paracetamol 15 mg/kg 4-6 hourly; no dose shown: the child's weight is not recorded."
    else:
        dose, daily = PARACETAMOL_CHILD.dose(weight), PARACETAMOL_CHILD.daily(weight)
        capped = " (capped at 1 g)" if dose < PARACETAMOL_CHILD.per_kg * weight else ""
        text = (
            f"Pain: paracetamol {dose:.0f} mg by mouth 4-6 hourly (15 mg/kg × {weight:g} kg{capped}); at most "
            f"{daily:.0f} mg in 24 hours (60 mg/kg/day, at most 4 g)."
        )
    return Recommendation(
        key="pain.paracetamol", category=RecommendationCategory.pain, text=text, inputs=used, source=source
    )


def _fentanyl(inputs: DecisionInputs, weight: float | None, used: list[InputUsed]) -> Recommendation | None:
    primary = inputs.primary
    age = inputs.age_years
    if primary is None or not primary.value.pain_poorly_controlled or age is None or age >= ADULT_FROM_YEARS:
        return None
    used = [*used, primary.used("pain poorly controlled", True)]
    blocked = allergy_to(inputs, "fentanyl")
    if blocked is not None:
        text = f"Severe pain: intranasal fentanyl is not advised: allergy recorded to {blocked[0]}."
        used.append(blocked[1])
    elif age < FENTANYL_FROM_YEARS:
        text = "Severe pain in a child under 12 months: intranasal fentanyl is contraindicated; seek senior advice."
    elif weight is None:
        text = "Severe pain: intranasal fentanyl 1.5 mcg/kg; no dose shown: the child's weight is not recorded."
    else:
        dose = FENTANYL_IN_CHILD.dose(weight)
        capped = " (capped at 75 mcg)" if dose < FENTANYL_IN_CHILD.per_kg * weight else ""
        text = (
            f"Severe pain: intranasal fentanyl {dose:.0f} mcg (1.5 mcg/kg × {weight:g} kg{capped}); a second dose "
            "of 0.75-1.5 mcg/kg may follow after 10 minutes, then review."
        )
    details = [
        "Not with an altered conscious state, blocked nasal passages or active epistaxis.",
        "Perth Children's Hospital gives a maximum dose of 100 mcg; the lower 75 mcg of the RCH table is used.",
    ]
    return Recommendation(
        key="pain.fentanyl_intranasal",
        category=RecommendationCategory.pain,
        text=text,
        details=details,
        inputs=used,
        source=RCH_ANALGESIA,
        urgent=True,
    )


def recommend(inputs: DecisionInputs) -> tuple[list[Recommendation], list[str]]:
    weight, weight_fact = inputs.weight_used()
    age = inputs.age_used()
    used = [fact for fact in (age, weight_fact) if fact is not None]
    out = [_paracetamol(inputs, weight, used)]
    fentanyl = _fentanyl(inputs, weight, used)
    if fentanyl is not None:
        out.append(fentanyl)
    opioid = pain_opioids.recommend(inputs, weight, used)
    if opioid is not None:
        out.append(opioid)
        out[0] = _with_detail(out[0], "Severe burn: oral doses are absorbed unreliably; the opioid is given IV.")
    missing = [] if weight is not None else ["weight: weight-based analgesic doses are not shown"]
    if inputs.age_years is not None and inputs.age_years < 12:
        out[0] = _with_detail(out[0], "No codeine under 12 years (MHRA 2013); no aspirin under 16 (NHS).")
    elif inputs.age_years is not None and inputs.age_years < 16:
        out[0] = _with_detail(out[0], "No aspirin under 16 years (NHS).")
    return out, missing


def _with_detail(recommendation: Recommendation, line: str) -> Recommendation:
    return msgspec.structs.replace(recommendation, details=[*recommendation.details, line])
