"""A major flame burn from a house fire, as the issue's new user tried it, and its parts one at a time.

An adult with facial burns, soot, a hoarse voice and a raised carboxyhaemoglobin, a pulseless right arm burned full
thickness all the way round, over 20 %TBSA, allergic to morphine and taking apixaban. Used by the rule tests
(as DecisionInputs, through the real calculators) and by the gateway test (as API bodies).
"""

from __future__ import annotations

import dataclasses
import datetime as dt

import msgspec

from processing.clinical.assessment import assess
from processing.clinical.decision_inputs import DecisionInputs
from schemas.burn_chart import BurnChart, BurnChartEntry, BurnDepth, LundBrowderRegion
from schemas.clinical_results import InputRef
from schemas.config import ClinicalConfig
from schemas.encounter_snapshot import Versioned
from schemas.ids import uuid7
from schemas.patient import Encounter, EncounterMode, Patient
from schemas.record_parts import (
    Airway,
    Allergy,
    Breathing,
    Circulation,
    Exposure,
    Intake,
    Mechanism,
    MechanismType,
    Medication,
    PrimarySurvey,
    TetanusDoses,
)
from schemas.records import RecordKind

INJURY = dt.datetime(2026, 11, 30, 9, 0, tzinfo=dt.UTC)
R, L = LundBrowderRegion, BurnDepth
CHART = [
    (R.head_anterior, 0.5, L.deep_partial, False),
    (R.trunk_anterior, 1.0, L.deep_partial, False),
    (R.upper_arm_right_anterior, 1.0, L.full_thickness, True),
    (R.upper_arm_right_posterior, 1.0, L.full_thickness, True),
    (R.lower_arm_right_anterior, 1.0, L.full_thickness, True),
    (R.lower_arm_right_posterior, 1.0, L.full_thickness, True),
]


def chart_entries() -> list[BurnChartEntry]:
    return [BurnChartEntry(region=r, fraction=f, depth=d, circumferential=c) for r, f, d, c in CHART]


def intake(encounter_id: str) -> Intake:
    return Intake(
        encounter_id=encounter_id,
        history_of_present_illness="House fire at night; found in a smoke-filled bedroom.",
        medications=[Medication(name="Apixaban", dose="5 mg twice daily")],
        allergies=[Allergy(substance="Morphine", reaction="rash and wheeze")],
        tetanus_doses=TetanusDoses.fewer_than_three,
    )


def primary(encounter_id: str, at: dt.datetime) -> PrimarySurvey:
    return PrimarySurvey(
        encounter_id=encounter_id,
        assessed_at=at,
        airway=Airway(patent=True, facial_burns=True, soot_in_mouth_or_nose=True, hoarse_voice=True),
        breathing=Breathing(respiratory_rate_per_min=24, spo2_percent=98, carboxyhaemoglobin_percent=18.0),
        circulation=Circulation(
            heart_rate_per_min=118, iv_access=True, circumferential_limb_burn=True, distal_pulses_present=False
        ),
        exposure=Exposure(temperature_c=36.4, burn_cooled=True, cooling_minutes=20),
    )


def mechanism(encounter_id: str) -> Mechanism:
    return Mechanism(encounter_id=encounter_id, type=MechanismType.flame, enclosed_space=True, agent="house fire")


def inputs(hours: float = 2.0, entries: list[BurnChartEntry] | None = None, **changes) -> DecisionInputs:
    """The case as the rules read it, `hours` after the injury, charted with `entries` (default: the case's);
    `changes` replace whole parts (None drops one)."""
    patient = Patient(id=uuid7(), date_of_birth=dt.date(1981, 5, 2), weight_kg=80.0, height_cm=178.0)
    encounter = Encounter(
        id=uuid7(),
        patient_id=patient.id,
        mode=EncounterMode.emergency,
        time_of_arrival=INJURY + dt.timedelta(hours=1),
        time_of_injury=INJURY,
    )
    eid = encounter.id
    at = INJURY + dt.timedelta(hours=hours)
    parts = {
        "intake": intake(eid),
        "primary": primary(eid, INJURY + dt.timedelta(hours=1)),
        "mechanism": mechanism(eid),
        "chart": BurnChart(
            encounter_id=eid, assessed_at=INJURY + dt.timedelta(hours=1), entries=entries or chart_entries()
        ),
    }
    parts.update(changes)
    kinds = {
        "chart": RecordKind.burn_chart,
        "mechanism": RecordKind.mechanism,
        "primary": RecordKind.primary_survey,
        "intake": RecordKind.intake,
    }
    ref = InputRef(kind="assessment", id=eid, version=1)
    assessment = assess(
        patient=patient,
        encounter=encounter,
        parts={kinds[k]: v for k, v in parts.items() if k in kinds and v is not None},
        inputs=[ref],
        as_of=at,
        config=ClinicalConfig(),
        computed_at=at,
        clock_skew_s=300,
    )
    versioned = {k: Versioned(v, InputRef(kind=k, id=eid, version=1)) for k, v in parts.items() if v is not None}
    return DecisionInputs(
        patient=Versioned(patient, InputRef(kind="patient", id=patient.id, version=1)),
        encounter=Versioned(encounter, InputRef(kind="encounter", id=eid, version=1)),
        as_of=at,
        age_years=assessment.age_years,
        assessment=Versioned(assessment, ref),
        **versioned,
    )


def with_part(base: DecisionInputs, name: str, **fields) -> DecisionInputs:
    """`base` with fields of one part changed (a nested Struct given whole)."""
    part = getattr(base, name)
    changed = msgspec.structs.replace(part.value, **fields)
    return dataclasses.replace(base, **{name: Versioned(changed, part.ref)})


def aged(base: DecisionInputs, age_years: float, weight_kg: float | None = None) -> DecisionInputs:
    """`base` for a patient of another age (and weight), as the calculators would have worked it out."""
    patient = base.patient.value
    if weight_kg is not None:
        patient = msgspec.structs.replace(patient, weight_kg=weight_kg)
    return dataclasses.replace(base, age_years=age_years, patient=Versioned(patient, base.patient.ref))


def with_mechanism(base: DecisionInputs, kind: MechanismType, **fields) -> DecisionInputs:
    m = Mechanism(encounter_id=base.encounter.value.id, type=kind, **fields)
    return dataclasses.replace(base, mechanism=Versioned(m, base.mechanism.ref))
