"""Run every clinical calculator on one encounter's record and say what could not be run.

A calculator runs when the record holds what it needs; otherwise `missing` names the data
to collect. A calculator that finds its data impossible (InvalidInput) does not stop the
others: its message goes to `calculator_errors` ("fluid plan: ..."), and the calculators that
need its result say so there too. One wrong part of a record must never block writing an
unrelated part: input wrong in itself is refused when it is written (validate_chart,
validate_resuscitation, the schemas); what lands here is what only shows once parts are put
together, e.g. a date of birth after the injury, or an injury after the assessment time.
Wrong calls still raise InvalidInput: a part of another encounter or of the wrong type, a kind
that is not an encounter part, times without a UTC offset, a negative clock-skew tolerance.

Every assessment also says where its inputs came from (`provenance`) and what limits it
(`caveats`): an estimated weight or age is stated, never hidden.
"""

from __future__ import annotations

import datetime as dt
from collections.abc import Callable
from typing import TypeVar

import msgspec

from processing.clinical.bsa import mosteller
from processing.clinical.checks import aware, check_age, check_weight, finite
from processing.clinical.fluids import fluid_plan
from processing.clinical.lund_browder import compute_tbsa
from processing.clinical.provenance import age_notes, chart_notes, num, weight_used
from processing.clinical.referral import ReferralInputs, assess_referral
from schemas.clinical_results import AgeSource, Assessment, FluidPlan, InputRef, TbsaResult
from schemas.config import ClinicalConfig
from schemas.errors import InvalidInput
from schemas.patient import Encounter, Patient
from schemas.record_parts import FluidFormula
from schemas.records import COMPUTED_PARTS, ENCOUNTER_PARTS, RECORD_TYPES, RecordKind

T = TypeVar("T")

DAYS_PER_YEAR = 365.25
INPUT_PARTS = ENCOUNTER_PARTS - COMPUTED_PARTS
"""The encounter parts the calculators read (the assessment is their output)."""

MISSING_AGE = "patient's date of birth or estimated age (needed for %TBSA and the fluid plan)"
MISSING_WEIGHT = "patient's weight in kg (needed for the fluid plan and body surface area)"
MISSING_HEIGHT = "patient's height in cm (needed for body surface area)"
MISSING_CHART = "burn chart (needed for %TBSA, the fluid plan and the referral criteria)"
MISSING_INJURY_TIME = "time of injury (needed for the fluid plan)"

AGE, WEIGHT, TBSA, BSA, FLUIDS, REFERRAL = "age", "weight", "%TBSA", "body surface area", "fluid plan", "referral"


class _Runner:
    """Runs calculators, turning each InvalidInput into a line of calculator_errors."""

    def __init__(self) -> None:
        self.errors: list[str] = []
        self.failed: set[str] = set()

    def run(self, name: str, fn: Callable[..., T], *args, **kwargs) -> T | None:
        try:
            return fn(*args, **kwargs)
        except InvalidInput as exc:
            self.errors.append(f"{name}: {exc.detail}")
            self.failed.add(name)
            return None

    def blocked(self, name: str, needs: str) -> bool:
        """Record that `name` cannot run because `needs` failed; True if it did fail."""
        if needs not in self.failed:
            return False
        self.errors.append(f"{name}: not computed: needs the {needs}, which could not be worked out (see {needs})")
        self.failed.add(name)
        return True


def _parts(parts: dict[RecordKind, msgspec.Struct], encounter: Encounter) -> dict[RecordKind, msgspec.Struct]:
    """The encounter parts by kind, checked to be of the right type and of this encounter."""
    checked = {}
    for given, part in parts.items():
        if given not in INPUT_PARTS:  # RecordKind is a StrEnum: the plain value "intake" is in it too
            allowed = ", ".join(sorted(k.value for k in INPUT_PARTS))
            raise InvalidInput(f"'{given}' is not an encounter part the calculators read (one of: {allowed})")
        kind = RecordKind(given)
        expected = RECORD_TYPES[kind]
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
    weight_source: str,
    tbsa: TbsaResult,
    age: float,
    parts: dict[RecordKind, msgspec.Struct],
    as_of: dt.datetime,
    config: ClinicalConfig,
    clock_skew_s: float,
) -> FluidPlan:
    resuscitation = parts.get(RecordKind.resuscitation)
    mechanism = parts.get(RecordKind.mechanism)
    return fluid_plan(
        weight_kg=weight,
        weight_source=weight_source,
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
        clock_skew_s=clock_skew_s,
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
    clock_skew_s: float,
) -> Assessment:
    """Every calculator the record allows, as of `as_of`, with what is missing or wrong for the rest.

    clock_skew_s: how far (s) the injury may lie after as_of and still count as clock drift
    (config.gateway.clock_skew_s).
    """
    aware(as_of, "assessment time")
    aware(computed_at, "computation time")
    skew = finite(clock_skew_s, "clock skew tolerance", 0, unit="s")
    if patient.id != encounter.patient_id:
        raise InvalidInput(f"encounter {encounter.id} belongs to patient {encounter.patient_id}, not {patient.id}")
    parts = _parts(parts, encounter)
    chart = parts.get(RecordKind.burn_chart)
    runner = _Runner()
    missing: list[str] = []
    provenance: list[str] = []
    caveats: list[str] = []

    age = runner.run(AGE, age_at_injury, patient, encounter)
    age_source: AgeSource = "date_of_birth" if patient.date_of_birth is not None else "estimate"
    if age is not None:
        line, notes = age_notes(patient, encounter, age)
        provenance.append(line)
        caveats += notes
    elif AGE not in runner.failed:
        missing.append(MISSING_AGE)

    weight, weight_source, line, notes = weight_used(patient, encounter)
    provenance.append(line)
    if weight is None:
        missing.append(MISSING_WEIGHT)
    elif runner.run(WEIGHT, check_weight, weight) is None:
        weight = None
    else:
        caveats += notes
    if chart is None:
        missing.append(MISSING_CHART)

    tbsa = None
    if chart is not None and not runner.blocked(TBSA, AGE) and age is not None:
        tbsa = runner.run(TBSA, compute_tbsa, chart, age, age_source=age_source)
        if tbsa is not None:
            line, notes = chart_notes(chart, encounter)
            provenance.append(line)
            caveats += notes

    bsa = None
    if patient.height_cm is None:
        missing.append(MISSING_HEIGHT)
    elif weight is not None:
        provenance.append(f"height {num(patient.height_cm)} cm, from the patient record")
        bsa = runner.run(BSA, mosteller, weight, patient.height_cm)
    else:
        runner.blocked(BSA, WEIGHT)

    fluids = None
    if encounter.time_of_injury is None:
        missing.append(MISSING_INJURY_TIME)
    elif weight is not None and tbsa is not None:
        args = (encounter, weight, weight_source, tbsa, age, parts, as_of, config, skew)
        fluids = runner.run(FLUIDS, _fluids, *args)
    elif not runner.blocked(FLUIDS, WEIGHT) and chart is not None:
        runner.blocked(FLUIDS, TBSA)

    referral = runner.run(
        REFERRAL,
        assess_referral,
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
        ),
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
        calculator_errors=runner.errors,
        provenance=provenance,
        caveats=caveats,
    )
