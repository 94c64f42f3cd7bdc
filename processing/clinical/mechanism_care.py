"""Care that depends on how the burn happened: electrical injury and chemical burns (hydrofluoric acid).

Electrical: an ECG for every electrical injury; cardiac monitoring for a high-voltage injury (1000 V or more),
loss of consciousness or an abnormal ECG (Emergency Medicine Practice 2009, after the ABA's 2006 guidelines);
pigmented urine after a high-voltage injury is run at 75-100 mL/h in adults until it clears (Joint Trauma System).
Chemical: irrigation with plenty of water while pain persists or until the skin pH is normal; hydrofluoric acid
gets calcium gluconate and cardiac monitoring (Victorian Adult Burns Service).
"""

from __future__ import annotations

import re

from processing.clinical.decision_inputs import ADULT_FROM_YEARS, DecisionInputs
from processing.clinical.sources_major import (
    EM_PRACTICE_ELECTRICAL,
    JTS_BURN_CARE,
    VICBURNS_CHEMICAL,
    VICBURNS_SEVERE_CHEMICAL,
)
from schemas.decision_support import Recommendation, RecommendationCategory
from schemas.record_parts import Avpu, MechanismType

HIGH_VOLTAGE_V = 1000.0
ELECTRICAL = (MechanismType.electrical_low_voltage, MechanismType.electrical_high_voltage, MechanismType.lightning)
HYDROFLUORIC = re.compile(r"hydrofluoric|\bHF\b|hydrogen fluoride", re.IGNORECASE)
PIGMENT_URINE_ML_H = (75, 100)
"""Joint Trauma System: adults with pigmented urine, until it clears."""


def recommend(inputs: DecisionInputs) -> tuple[list[Recommendation], list[str]]:
    if inputs.mechanism is None:
        return [], []
    kind = inputs.mechanism.value.type
    if kind in ELECTRICAL:
        return _electrical(inputs), []
    if kind is MechanismType.chemical:
        return _chemical(inputs), []
    return [], []


def high_voltage(inputs: DecisionInputs) -> bool:
    m = inputs.mechanism.value
    return m.type in (MechanismType.electrical_high_voltage, MechanismType.lightning) or (
        m.voltage_v is not None and m.voltage_v >= HIGH_VOLTAGE_V
    )


def _electrical(inputs: DecisionInputs) -> list[Recommendation]:
    m = inputs.mechanism
    used = [m.used("mechanism", m.value.type)]
    if m.value.voltage_v is not None:
        used.append(m.used("voltage", f"{m.value.voltage_v:g} V"))
    reasons = []
    high = high_voltage(inputs)
    if high:
        reasons.append("a high-voltage injury (1000 V or more)")
    disability = inputs.primary.value.disability if inputs.primary is not None else None
    if disability is not None and disability.avpu not in (None, Avpu.alert):
        used.append(inputs.primary.used("AVPU", disability.avpu))
        reasons.append(f"a reduced level of consciousness (AVPU: {disability.avpu.value})")
    monitor = (
        f"Cardiac monitoring: indicated for {' and '.join(reasons)}."
        if reasons
        else "Cardiac monitoring if the ECG shows an arrhythmia or ischaemia, or consciousness was lost."
    )
    out = [
        Recommendation(
            key="mechanism.electrical_heart",
            category=RecommendationCategory.mechanism,
            text=f"Electrical injury: a 12-lead ECG now. {monitor}",
            details=["Entry and exit wounds can hide deep damage to muscle: watch the limbs for compartment syndrome."],
            inputs=used,
            source=EM_PRACTICE_ELECTRICAL,
            urgent=bool(reasons),
        )
    ]
    if high:
        out.append(_pigmented_urine(inputs, used))
    return out


def _pigmented_urine(inputs: DecisionInputs, used: list) -> Recommendation:
    low, high = PIGMENT_URINE_ML_H
    age = inputs.age_years
    if age is not None and age >= ADULT_FROM_YEARS:
        target = f"adjust the fluids to keep the urine output at {low}-{high} mL/h until the urine clears"
    else:
        target = (
            "the source gives the adult target only (75-100 mL/h until the urine clears); for a child, seek the "
            "burn service's advice"
        )
    facts = [*used, *([inputs.age_used()] if age is not None else [])]
    return Recommendation(
        key="mechanism.electrical_urine",
        category=RecommendationCategory.mechanism,
        text=f"High-voltage injury: watch for dark (red or brown) urine from muscle damage; if it appears, {target}.",
        details=["Creatine kinase every 6 hours where it can be measured; a urine dipstick does not say when to stop."],
        inputs=facts,
        source=JTS_BURN_CARE,
    )


def _chemical(inputs: DecisionInputs) -> list[Recommendation]:
    m = inputs.mechanism
    used = [m.used("mechanism", m.value.type)]
    if m.value.agent:
        used.append(m.used("agent", m.value.agent))
    out = [
        Recommendation(
            key="mechanism.chemical_irrigation",
            category=RecommendationCategory.mechanism,
            text="Chemical burn: irrigate with plenty of running water as soon as possible, and keep going while the "
            "pain persists or until the skin's pH is normal (compare with unburned skin on a pH strip).",
            details=[
                "Carers wear gloves, gown and eye protection. Remove contaminated clothing; brush off a powder "
                "before wetting; do not wash the chemical over unburned skin.",
                "An eye: irrigate with the unaffected eye uppermost.",
                "Keep the patient warm while irrigating.",
            ],
            inputs=used,
            source=VICBURNS_CHEMICAL,
            urgent=True,
        )
    ]
    if m.value.agent and HYDROFLUORIC.search(m.value.agent):
        out.append(
            Recommendation(
                key="mechanism.hydrofluoric_acid",
                category=RecommendationCategory.mechanism,
                text="Hydrofluoric acid: after irrigation, neutralise the fluoride with calcium gluconate gel on the "
                "burn, or local injection of 10 % calcium gluconate; it can cause arrhythmias: ECG and cardiac "
                "monitoring, and seek the burn service's or a poisons centre's advice now.",
                details=[
                    "Very small amounts of industrial-strength acid can be fatal.",
                    "An eye: copious water, not calcium gluconate, at first.",
                    "Poisons centres (BC Drug and Poison Information Centre; TOXINZ) give a 2.5 % gel, and discharge "
                    "only with a normal ECG and serum calcium.",
                ],
                inputs=used,
                source=VICBURNS_SEVERE_CHEMICAL,
                urgent=True,
            )
        )
    return out
