"""Wound care: first-aid cooling while it can still help. Dressing classes, cleaning, blisters, elevation and
re-dressing intervals are not given: their sources could not be checked (docs/clinical.md)."""

from __future__ import annotations

import datetime as dt

from processing.clinical.decision_inputs import DecisionInputs
from processing.clinical.sources import ANZCOR_FIRST_AID
from schemas.decision_support import Recommendation, RecommendationCategory

COOLING_WINDOW_H = 3.0
COOLING_MIN = 20.0


def recommend(inputs: DecisionInputs) -> tuple[list[Recommendation], list[str]]:
    injury = inputs.injury_time
    hours = inputs.hours_since_injury()
    if injury is None or hours is None:
        return [], ["time of injury: whether cooling can still help is not judged"]
    if hours >= COOLING_WINDOW_H or hours < 0:
        return [], []
    exposure = inputs.primary.value.exposure if inputs.primary else None
    minutes = exposure.cooling_minutes if exposure else None
    if exposure is not None and exposure.burn_cooled and minutes is not None and minutes >= COOLING_MIN:
        return [], []
    until = (injury + dt.timedelta(hours=COOLING_WINDOW_H)).strftime("%H:%M UTC")
    done = f" ({minutes:g} min recorded so far)" if minutes else ""
    used = [inputs.encounter.used("time of injury", injury)]
    if inputs.primary is not None:
        used.append(inputs.primary.used("cooling recorded", f"{_yes(exposure.burn_cooled)}, {minutes or 0:g} min"))
    text = (
        f"Cool the burn under cool running water for at least {COOLING_MIN:g} minutes{done}: cooling may still help "
        f"until {until}, 3 hours after the injury. Keep the rest of the patient warm; no ice."
    )
    return [
        Recommendation(
            key="wound_care.cooling",
            category=RecommendationCategory.wound_care,
            text=text,
            details=["Remove jewellery and clothing not stuck to the burn."],
            inputs=used,
            source=ANZCOR_FIRST_AID,
            urgent=True,
        )
    ], []


def _yes(value: bool | None) -> str:
    return "not recorded" if value is None else "yes" if value else "no"
