"""Circulation to burned limbs and the chest: neurovascular checks, elevation, and when escharotomy is considered.

A circumferential deep burn (deep partial or full thickness) of a limb, from the chart or the primary survey, gets
hourly neurovascular checks and elevation (Joint Trauma System), with the Victorian Adult Burns Service's signs of
compromise. Absent distal pulses with such a burn, or a circumferential chest burn that restricts breathing, are
urgent: the burn surgeon is consulted at once about escharotomy or transfer. A recorded anticoagulant is named,
since escharotomy bleeds; what to do about it is the surgeon's call (no source checked says).
"""

from __future__ import annotations

from processing.clinical.decision_inputs import DecisionInputs
from processing.clinical.medicines import anticoagulants
from processing.clinical.sources_major import JTS_BURN_CARE, VICBURNS_CIRCUMFERENTIAL
from schemas.burn_chart import BurnDepth, region_name
from schemas.decision_support import InputUsed, Recommendation, RecommendationCategory

DEEP = (BurnDepth.deep_partial, BurnDepth.full_thickness)
LIMB_WORDS = ("arm", "hand", "thigh", "leg", "foot")
CHECKS = (
    "Check the limb's circulation hourly (Joint Trauma System): colour, pulses (Doppler if available), capillary "
    "refill, warmth, pain and sensation. Elevate the limb above the heart."
)
SIGNS = (
    "Signs of compromise (Victorian Adult Burns Service): loss of distal pulses, a cool limb, numbness or increasing "
    "pain, falling pulse oximetry on that limb. These are late signs: consider escharotomy when the eschar is tight, "
    "after discussion with the burn service. It is not usually needed in the first 6 hours."
)


def _circumferential(inputs: DecisionInputs, words: tuple[str, ...], recorded: bool, label: str):
    """The charted regions (named by `words`) burned deep all the way round, and the facts: the chart's, and the
    primary survey's flag `label` when `recorded`; ([], []) when neither says so."""
    chart = inputs.chart
    regions = sorted(
        {
            region_name(e.region).lower()
            for e in chart.value.entries
            if e.circumferential and e.depth in DEEP and any(w in e.region.value for w in words)
        }
        if chart is not None
        else ()
    )
    used: list[InputUsed] = []
    if regions:
        used.append(chart.used("circumferential deep burn charted", "; ".join(regions)))
    if recorded:
        used.append(inputs.primary.used(label, True))
    return regions, used


def _anticoagulant_line(inputs: DecisionInputs, used: list[InputUsed], then: str) -> list[str]:
    """The detail naming a recorded anticoagulant (its facts added to `used`), or none."""
    medicines = anticoagulants(inputs)
    used += medicines
    names = "; ".join(m.value for m in medicines)
    return [f"Anticoagulant recorded: {names}. {then}"] if medicines else []


def recommend(inputs: DecisionInputs) -> tuple[list[Recommendation], list[str]]:
    return _limb(inputs) + _chest(inputs), []


def _limb(inputs: DecisionInputs) -> list[Recommendation]:
    circulation = inputs.primary.value.circulation if inputs.primary is not None else None
    recorded = circulation is not None and circulation.circumferential_limb_burn
    regions, used = _circumferential(inputs, LIMB_WORDS, recorded, "circumferential limb burn")
    if not used:
        return []
    pulseless = circulation is not None and circulation.distal_pulses_present is False
    if pulseless:
        used.append(inputs.primary.used("distal pulses present", False))
    where = f" ({'; '.join(regions)})" if regions else ""
    details = [
        *_anticoagulant_line(inputs, used, "Escharotomy is expected to bleed: tell the burn surgeon."),
        CHECKS,
        SIGNS,
    ]
    if pulseless:
        text = (
            f"Circulation: absent distal pulses with a circumferential burn of a limb{where}. Rule out low blood "
            "volume, then consult the burn surgeon now about escharotomy or urgent transfer."
        )
    else:
        text = (
            f"Circulation: circumferential deep burn of a limb{where}: hourly neurovascular checks, elevate the "
            "limb, and watch for the signs that call for escharotomy."
        )
    source = JTS_BURN_CARE if pulseless else VICBURNS_CIRCUMFERENTIAL
    return [
        Recommendation(
            key="circulation.limb",
            category=RecommendationCategory.circulation,
            text=text,
            details=details,
            inputs=used,
            source=source,
            urgent=pulseless,
        )
    ]


def _chest(inputs: DecisionInputs) -> list[Recommendation]:
    breathing = inputs.primary.value.breathing if inputs.primary is not None else None
    recorded = breathing is not None and breathing.circumferential_chest_burn
    _, used = _circumferential(inputs, ("trunk",), recorded, "circumferential chest burn")
    if not used:
        return []
    restricted = breathing is not None and breathing.chest_movement_restricted is True
    if restricted:
        used.append(inputs.primary.used("chest movement restricted", True))
        text = (
            "Breathing: a circumferential chest burn restricts breathing: consult the burn surgeon now about chest "
            "escharotomy or urgent transfer."
        )
    else:
        text = (
            "Breathing: circumferential burn of the chest: sit the patient up and watch for restricted breathing "
            "(shallow breaths, difficulty breathing, rising ventilation pressures), which calls for chest escharotomy."
        )
    details = [
        *_anticoagulant_line(inputs, used, "Expect bleeding (Joint Trauma System): tell the surgeon."),
        "Chest escharotomy is done after the burn service's advice (Victorian Adult Burns Service).",
    ]
    return [
        Recommendation(
            key="breathing.chest_escharotomy",
            category=RecommendationCategory.breathing,
            text=text,
            details=details,
            inputs=used,
            source=JTS_BURN_CARE if restricted else VICBURNS_CIRCUMFERENTIAL,
            urgent=restricted,
        )
    ]
