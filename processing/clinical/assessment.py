"""Run every clinical calculator on one encounter's record and say what could not be run.

A calculator runs when the record holds what it needs; otherwise `missing` names the data
to collect. Impossible data (InvalidInput) is never swallowed: it propagates, so a wrong
weight or a future injury time is corrected rather than hidden behind a partial result.
"""

from __future__ import annotations

import datetime as dt

import msgspec

from processing.clinical.bsa import mosteller
from processing.clinical.fluids import fluid_plan
from processing.clinical.lund_browder import check_age, compute_tbsa
from processing.clinical.referral import ReferralInputs, assess_referral
from schemas.clinical_results import Assessment, FluidPlan, InputRef, TbsaResult
from schemas.config import ClinicalConfig
from schemas.errors import InvalidInput
from schemas.patient import Encounter, Patient
from schemas.record_parts import FluidFormula
from schemas.records import RECORD_TYPES, RecordKind

DAYS_PER_YEAR = 365.25

MISSING_AGE = "patient's date of birth or estimated age (needed for %TBSA and the fluid plan)"
MISSING_WEIGHT = "patient's weight in kg (needed for the fluid plan and body surface area)"
MISSING_HEIGHT = "patient's height in cm (needed for body surface area)"
MISSING_CHART = "burn chart (needed for %TBSA, the fluid plan and the referral criteria)"
MISSING_INJURY_TIME = "time of injury (needed for the fluid plan)"


def _aware(value: dt.datetime, what: str) -> dt.datetime:
    if not isinstance(value, dt.datetime) or value.tzinfo is None or value.utcoffset() is None:
        raise InvalidInput(f"{what} {value!r} has no UTC offset: give it with its time zone")
    return value


def _parts(parts: dict[RecordKind, msgspec.Struct], encounter: Encounter) -> dict[RecordKind, msgspec.Struct]:
    """The encounter parts by kind, checked to be of the right type and of this encounter."""
    checked = {}
    for kind, part in parts.items():
        try:
            kind = RecordKind(kind)
            expected = RECORD_TYPES[kind]
        except (ValueError, KeyError):
            raise InvalidInput(f"'{kind}' is not an encounter part the calculators read") from None
        if not isinstance(part, expected):
            raise InvalidInput(f"the {kind.value} part is a {type(part).__name__}, not a {expected.__name__}")
        if part.encounter_id != encounter.id:
            raise InvalidInput(f"the {kind.value} part belongs to encounter {part.encounter_id}, not {encounter.id}")
        checked[kind] = part
    return checked


def age_at_injury(patient: Patient, encounter: Encounter) -> float | None:
    """Age in years on the day of injury (or arrival), from the date of birth or the estimate."""
    if patient.date_of_birth is not None:
        when = encounter.time_of_injury or encounter.time_of_arrival
        days = (when.date() - patient.date_of_birth).days
        if days < 0:
            raise InvalidInput(
                f"date of birth {patient.date_of_birth.isoformat()} is after the injury "
                f"({when.date().isoformat()}): check the date of birth"
            )
        return check_age(days / DAYS_PER_YEAR)
    if patient.age_estimate_years is not None:
        return check_age(patient.age_estimate_years)
    return None


def _fluids(
    encounter: Encounter,
    weight: float,
    tbsa: TbsaResult,
    age: float,
    parts: dict[RecordKind, msgspec.Struct],
    as_of: dt.datetime,
    config: ClinicalConfig,
) -> FluidPlan:
    resuscitation = parts.get(RecordKind.resuscitation)
    mechanism = parts.get(RecordKind.mechanism)
    return fluid_plan(
        weight_kg=weight,
        tbsa_percent=tbsa.tbsa_percent,
        age_years=age,
        mechanism=mechanism.type if mechanism is not None else None,
        time_of_injury=encounter.time_of_injury,
        as_of=as_of,
        fluid_given=resuscitation.fluid_given if resuscitation is not None else [],
        formula=resuscitation.formula if resuscitation is not None else FluidFormula.parkland,
        custom_ml_per_kg_per_percent=(
            resuscitation.custom_ml_per_kg_per_percent if resuscitation is not None else None
        ),
        config=config,
    )


def assess(
    *,
    patient: Patient,
    encounter: Encounter,
    parts: dict[RecordKind, msgspec.Struct],
    inputs: list[InputRef],
    as_of: dt.datetime,
    config: ClinicalConfig,
    computed_at: dt.datetime,
) -> Assessment:
    """Every calculator the record allows, as of `as_of`, with what is missing for the rest."""
    _aware(as_of, "assessment time")
    _aware(computed_at, "computation time")
    if patient.id != encounter.patient_id:
        raise InvalidInput(f"encounter {encounter.id} belongs to patient {encounter.patient_id}, not {patient.id}")
    parts = _parts(parts, encounter)
    chart = parts.get(RecordKind.burn_chart)
    age = age_at_injury(patient, encounter)
    weight = encounter.weight_kg if encounter.weight_kg is not None else patient.weight_kg

    missing = []
    if age is None:
        missing.append(MISSING_AGE)
    if weight is None:
        missing.append(MISSING_WEIGHT)
    if chart is None:
        missing.append(MISSING_CHART)
    tbsa = compute_tbsa(chart, age) if chart is not None and age is not None else None

    bsa = None
    if patient.height_cm is None:
        missing.append(MISSING_HEIGHT)
    elif weight is not None:
        bsa = mosteller(weight, patient.height_cm)

    fluids = None
    if encounter.time_of_injury is None:
        missing.append(MISSING_INJURY_TIME)
    elif weight is not None and tbsa is not None:
        fluids = _fluids(encounter, weight, tbsa, age, parts, as_of, config)

    referral = assess_referral(
        ReferralInputs(
            age_years=age,
            weight_kg=weight,
            tbsa=tbsa,
            chart=chart,
            mechanism=parts.get(RecordKind.mechanism),
            primary=parts.get(RecordKind.primary_survey),
            secondary=parts.get(RecordKind.secondary_survey),
            intake=parts.get(RecordKind.intake),
            config=config,
        )
    )
    return Assessment(
        encounter_id=encounter.id,
        computed_at=computed_at,
        as_of=as_of,
        inputs=list(inputs),
        age_years=round(age, 2) if age is not None else None,
        weight_kg=weight,
        tbsa=tbsa,
        bsa=bsa,
        fluids=fluids,
        referral=referral,
        missing=missing,
    )
