"""Oxygen for carbon monoxide: an enclosed-space fire, a raised carboxyhaemoglobin or signs of inhalation injury.

100 % high-flow (15 L/min) humidified oxygen (Victorian Adult Burns Service), continued until symptoms subside and
COHb is under 5 %; a COHb over 10 % always signifies poisoning; pulse oximetry reads falsely normal (EBMG).
"""

from __future__ import annotations

from processing.clinical.airway import COHB_RAISED_OVER, signs_present
from processing.clinical.decision_inputs import DecisionInputs
from processing.clinical.sources_major import EBMG_CARBON_MONOXIDE, VICBURNS_BREATHING
from schemas.decision_support import Recommendation, RecommendationCategory

POISONING_OVER_PERCENT = COHB_RAISED_OVER
UNTIL_UNDER_PERCENT = 5.0


def cohb(inputs: DecisionInputs) -> float | None:
    return inputs.primary.value.breathing.carboxyhaemoglobin_percent if inputs.primary is not None else None


def recommend(inputs: DecisionInputs) -> tuple[list[Recommendation], list[str]]:
    level = cohb(inputs)
    poisoned = level is not None and level > POISONING_OVER_PERCENT
    signs = signs_present(inputs)
    if not poisoned and not signs:
        return [], []
    used = list(signs)
    if level is not None and not poisoned:
        used.append(inputs.primary.used("carboxyhaemoglobin", f"{level:g} %"))
    why = (
        f"carboxyhaemoglobin {level:g} % (over {POISONING_OVER_PERCENT:g} %: carbon monoxide poisoning)"
        if poisoned
        else "smoke or an enclosed-space fire: carbon monoxide poisoning is possible"
    )
    text = (
        f"Oxygen: {why}. Give 100 % high-flow oxygen (15 L/min, humidified) by a non-rebreathing mask or the tube, "
        f"and continue until the symptoms subside and carboxyhaemoglobin is under {UNTIL_UNDER_PERCENT:g} %."
    )
    details = [
        "Pulse oximetry cannot tell carboxyhaemoglobin from oxyhaemoglobin: a normal SpO2 does not rule out "
        "carbon monoxide poisoning. Measure COHb on a blood gas.",
        "Carbon monoxide poisoning with a burn: consult the burn centre (EBMG).",
    ]
    missing = [] if level is not None else ["carboxyhaemoglobin: not recorded; measure it on a blood gas"]
    return [
        Recommendation(
            key="breathing.oxygen",
            category=RecommendationCategory.breathing,
            text=text,
            details=details,
            inputs=used,
            source=EBMG_CARBON_MONOXIDE if poisoned else VICBURNS_BREATHING,
            urgent=True,
        )
    ], missing
