"""Keeping a patient with a large burn warm.

Burns over 20 %TBSA are at high risk of hypothermia (Joint Trauma System); children, intubated patients and the
elderly are at risk too (Victorian Adult Burns Service). Below 36 °C: rewarm actively (Joint Trauma System, prolonged
field care); below 35 °C: stop cooling the burn (Victorian Adult Burns Service).
"""

from __future__ import annotations

from processing.clinical.decision_inputs import DecisionInputs
from processing.clinical.sources_major import JTS_BURN_CARE, JTS_PFC_BURN
from schemas.decision_support import InputUsed, Recommendation, RecommendationCategory

LARGE_BURN_OVER = 20.0
"""%TBSA over which the Joint Trauma System calls a burn at high risk of hypothermia."""
REWARM_BELOW_C = 36.0
STOP_COOLING_BELOW_C = 35.0
MEASURES = (
    "Cover the burn as soon as it is assessed; warm blankets or forced-air warming; warm IV fluids; a warm room or "
    "vehicle; remove wet sheets and dressings; check the temperature regularly (Victorian Adult Burns Service)."
)


def temperature(inputs: DecisionInputs) -> float | None:
    """The temperature the primary survey recorded, in °C."""
    return inputs.primary.value.exposure.temperature_c if inputs.primary is not None else None


def recommend(inputs: DecisionInputs) -> tuple[list[Recommendation], list[str]]:
    tbsa = inputs.assessment.value.tbsa if inputs.assessment is not None else None
    large = tbsa is not None and tbsa.tbsa_percent > LARGE_BURN_OVER
    celsius = temperature(inputs)
    cold = celsius is not None and celsius < REWARM_BELOW_C
    if not large and not cold:
        return [], []
    used: list[InputUsed] = []
    parts = []
    if large:
        used.append(inputs.assessment.used("%TBSA", f"{tbsa.tbsa_percent:g} %"))
        parts.append(f"a burn of {tbsa.tbsa_percent:g} %TBSA (over {LARGE_BURN_OVER:g} %: high risk of hypothermia)")
    if celsius is not None:
        used.append(inputs.primary.used("temperature", f"{celsius:g} °C"))
    if cold:
        parts.append(f"a temperature of {celsius:g} °C (under {REWARM_BELOW_C:g} °C)")
    text = "Keep warm: " + " and ".join(parts) + "."
    if cold:
        text += " Rewarm actively now."
    if celsius is not None and celsius < STOP_COOLING_BELOW_C:
        text += f" Stop cooling the burn: the temperature is under {STOP_COOLING_BELOW_C:g} °C."
    missing = [] if celsius is not None else ["temperature: hypothermia in a large burn is not judged"]
    return [
        Recommendation(
            key="temperature.warmth",
            category=RecommendationCategory.temperature,
            text=text,
            details=[MEASURES],
            inputs=used,
            source=JTS_PFC_BURN if cold else JTS_BURN_CARE,
            urgent=cold,
        )
    ], missing
