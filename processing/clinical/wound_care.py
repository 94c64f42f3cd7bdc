"""Wound care: first-aid cooling while it can still help, the dressing by the clinician's charted depth (never
the measured relief), and elevation of a burned limb. Cleaning, blister handling, re-dressing intervals and the
dressing of deep burns are not given: their sources could not be checked (docs/clinical.md)."""

from __future__ import annotations

import datetime as dt

from processing.clinical.decision_inputs import DecisionInputs
from processing.clinical.sources import ANZCOR_FIRST_AID, ELEVATION, VICBURNS_DRESSINGS
from processing.clinical.temperature import STOP_COOLING_BELOW_C
from schemas.burn_chart import BurnDepth, region_name
from schemas.decision_support import Recommendation, RecommendationCategory

COOLING_WINDOW_H = 3.0
COOLING_MIN = 20.0


DEPTH_ORDER = list(BurnDepth)
LIMB_WORDS = ("arm", "hand", "thigh", "leg", "foot")
DRESSING = {
    BurnDepth.superficial: (
        "Dressing (epidermal burn, as charted): simple moisturiser; no secondary dressing needed. Expected to heal in "
        "3-7 days; follow-up should not be required."
    ),
    BurnDepth.superficial_partial: (
        "Dressing (superficial partial-thickness burn, as charted): paraffin gauze or a silicone dressing, silver "
        "products only if the wound is contaminated, under an absorbent secondary dressing (gauze or foam). Expected "
        "to heal within 7-10 days; dermal burns exude heavily in the first 72 hours."
    ),
}


def recommend(inputs: DecisionInputs) -> tuple[list[Recommendation], list[str]]:
    made, missing = _cooling(inputs)
    return made + _dressing(inputs) + _elevation(inputs), missing


def _dressing(inputs: DecisionInputs) -> list[Recommendation]:
    chart = inputs.chart
    if chart is None or not chart.value.entries:
        return []
    deepest = max((e.depth for e in chart.value.entries), key=DEPTH_ORDER.index)
    used = [chart.used("deepest depth charted", deepest)]
    text = DRESSING.get(deepest) or (
        f"Dressing: the chart records a {deepest.value.replace('_', ' ')} burn; no dressing class is given here (the "
        "sources read give none for deep burns): dress as the burn service advises (see the referral advice)."
    )
    return [
        Recommendation(
            key="wound_care.dressing",
            category=RecommendationCategory.wound_care,
            text=text,
            inputs=used,
            source=VICBURNS_DRESSINGS,
        )
    ]


def _elevation(inputs: DecisionInputs) -> list[Recommendation]:
    chart = inputs.chart
    limbs = (
        sorted({e.region.value for e in chart.value.entries if any(w in e.region.value for w in LIMB_WORDS)})
        if chart
        else []
    )
    if not limbs:
        return []
    return [
        Recommendation(
            key="wound_care.elevation",
            category=RecommendationCategory.wound_care,
            text="Elevate the burned limb to reduce swelling.",
            inputs=[chart.used("limb regions burned", "; ".join(region_name(r).lower() for r in limbs))],
            source=ELEVATION,
        )
    ]


def _cooling(inputs: DecisionInputs) -> tuple[list[Recommendation], list[str]]:
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
    if exposure is not None and exposure.temperature_c is not None and exposure.temperature_c < STOP_COOLING_BELOW_C:
        return [], []  # too cold to cool: processing/clinical/temperature.py says to stop
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
