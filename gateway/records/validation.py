"""Checks a record must pass before it is stored: schema, identity, references, clinical times."""

from __future__ import annotations

import datetime as dt
import re
import sqlite3
import zoneinfo

import msgspec

from base.storage import records as store
from processing.clinical.fluids import validate_resuscitation
from processing.clinical.lund_browder import validate_chart
from schemas.base import utcnow
from schemas.burn_chart import BurnChart
from schemas.config import Config
from schemas.errors import InvalidInput, NotFound
from schemas.patient import Encounter, Patient
from schemas.problem import FieldProblem
from schemas.record_parts import Intake, PrimarySurvey, Resuscitation, SecondarySurvey
from schemas.records import ENCOUNTER_PARTS, PATIENT_RECORDS, RECORD_TYPES, Record, RecordKind

_AT_PATH = re.compile(r"^(?P<msg>.*?)(?: - at `(?P<path>[^`]*)`)?$", re.S)


def field_problem(exc: msgspec.ValidationError) -> FieldProblem:
    """Split msgspec's "Expected `int`, got `str` - at `$.weight_kg`" into path and message."""
    m = _AT_PATH.match(str(exc))
    return FieldProblem(field=m["path"] or "$", message=m["msg"])


def to_struct(kind: RecordKind, data: object) -> msgspec.Struct:
    struct_type = RECORD_TYPES[kind]
    if isinstance(data, struct_type):
        return data
    if not isinstance(data, dict):
        raise InvalidInput(f"{kind.value} data must be a JSON object")
    try:
        return msgspec.convert(data, struct_type)
    except msgspec.ValidationError as exc:
        problem = field_problem(exc)
        raise InvalidInput(f"{kind.value}: {problem.message} at {problem.field}", errors=[problem]) from exc


def bad_field(field: str, message: str) -> InvalidInput:
    return InvalidInput(f"{message} ({field})", errors=[FieldProblem(field=field, message=message)])


def not_future(value: dt.datetime | None, field: str, config: Config) -> None:
    now = utcnow()
    if value is not None and value > now + dt.timedelta(seconds=config.gateway.clock_skew_s):
        raise bad_field(field, future_message(value, now, config))


def future_message(value: dt.datetime, now: dt.datetime, config: Config) -> str:
    """ "2026-03-01 14:30 is in the future: 2 h 05 min ahead of the clinic clock (now 12:25, Africa/Nairobi)...",
    in the clinic's zone ([gateway] timezone), as the person typed it."""
    zone = zoneinfo.ZoneInfo(config.gateway.timezone) if config.gateway.timezone else None
    local, clock = value.astimezone(zone), now.astimezone(zone)
    name = config.gateway.timezone or clock.tzname() or "clinic time"
    # Counted from the clinic clock as shown (to the minute), so the figures add up for the person reading them.
    minutes = int((value - now.replace(second=0, microsecond=0)).total_seconds() // 60)
    ahead = f"{minutes // 60} h {minutes % 60:02d} min" if minutes >= 60 else f"{max(minutes, 1)} min"
    allowed = config.gateway.clock_skew_s // 60
    return (
        f"{local:%Y-%m-%d %H:%M} is in the future: {ahead} ahead of the clinic clock (now {clock:%H:%M}, {name}). "
        f"Check the time entered"
        + (f" (up to {allowed} min ahead is accepted)" if allowed else "")
        + " and the device's clock."
    )


def check(conn: sqlite3.Connection, kind: RecordKind, record_id: str, struct, config: Config) -> str | None:
    """Raise InvalidInput/NotFound if the record cannot be stored; return its parent id."""
    if kind is RecordKind.patient:
        _check_patient(record_id, struct)
        return None
    if kind is RecordKind.encounter:
        _check_encounter(conn, record_id, struct, config)
        return struct.patient_id
    if kind not in ENCOUNTER_PARTS:
        # A domain package's kind (a wound) is checked by the rules it hands the record service.
        raise InvalidInput(f"this gateway has no checks for {kind.label} records: they cannot be stored")
    if struct.encounter_id != record_id:
        raise bad_field(
            "$.encounter_id",
            f"encounter_id {struct.encounter_id} does not match the encounter {record_id} in the address",
        )
    require_live_encounter(conn, record_id)
    if isinstance(struct, (PrimarySurvey, SecondarySurvey, BurnChart)):
        not_future(struct.assessed_at, "$.assessed_at", config)
    if isinstance(struct, BurnChart):
        validate_chart(struct)
    if isinstance(struct, Intake):
        _check_intake(struct)
    if isinstance(struct, Resuscitation):
        validate_resuscitation(struct)
        for i, given in enumerate(struct.fluid_given):
            not_future(given.given_at, f"$.fluid_given[{i}].given_at", config)
    return record_id


NAMELESS = (
    "a patient needs a name or a medical record number; for an unknown patient, give a temporary label "
    "(e.g. 'Unknown man, bay 3')"
)


def _check_patient(record_id: str, patient: Patient) -> None:
    if patient.id != record_id:
        raise bad_field("$.id", f"id {patient.id} does not match {record_id} in the address")
    if not any(s and s.strip() for s in (patient.given_name, patient.family_name, patient.medical_record_number)):
        if not (patient.temporary_label or "").strip():
            raise bad_field("$.given_name", NAMELESS)
    # The gateway's UTC date can be a day behind the bedside's local date.
    if patient.date_of_birth is not None and patient.date_of_birth > utcnow().date() + dt.timedelta(days=1):
        raise bad_field("$.date_of_birth", "date of birth is in the future")


def _check_intake(intake: Intake) -> None:
    last = intake.last_tetanus_dose
    if last is not None and last > utcnow().date() + dt.timedelta(days=1):
        raise bad_field("$.last_tetanus_dose", "the last tetanus dose is dated in the future")
    if last is not None and intake.years_since_last_tetanus_dose is not None:
        raise bad_field(
            "$.years_since_last_tetanus_dose",
            "give the date of the last tetanus dose or the years since it, not both",
        )


def _check_encounter(conn: sqlite3.Connection, record_id: str, enc: Encounter, config: Config) -> None:
    if enc.id != record_id:
        raise bad_field("$.id", f"id {enc.id} does not match {record_id} in the address")
    require_live(conn, RecordKind.patient, enc.patient_id)
    not_future(enc.time_of_arrival, "$.time_of_arrival", config)
    not_future(enc.time_of_injury, "$.time_of_injury", config)
    if enc.time_of_injury is not None and enc.time_of_injury > enc.time_of_arrival:
        raise bad_field("$.time_of_injury", "the time of injury is after the time of arrival")


def require_live(conn: sqlite3.Connection, kind: RecordKind, record_id: str) -> Record:
    head = store.find_head(conn, kind, record_id)
    if head is None:
        raise NotFound(f"no {kind.label} with id {record_id}: create it first")
    if head.meta.deleted:
        raise InvalidInput(f"the {kind.label} {record_id} was withdrawn: records cannot be added to it")
    return head


def require_live_encounter(conn: sqlite3.Connection, encounter_id: str) -> Record:
    """The encounter, if it and its patient exist and are not withdrawn."""
    encounter = require_live(conn, RecordKind.encounter, encounter_id)
    require_live(conn, RecordKind.patient, encounter.value().patient_id)
    return encounter


def check_unchanged_links(kind: RecordKind, struct, current: Record) -> None:
    """An update may not move a record to another patient or encounter, nor mark a patient as merged (only a merge
    does: gateway/records/merge.py; restoring a merged patient may clear it)."""
    if kind is RecordKind.patient and struct.merged_into and struct.merged_into != current.data.get("merged_into"):
        raise bad_field("$.merged_into", "a patient is marked as merged only by merging the two records")
    if kind in PATIENT_RECORDS and struct.patient_id != current.value().patient_id:
        again = "open a new one" if kind is RecordKind.encounter else "record a new one"
        raise bad_field("$.patient_id", f"{_article(kind)} cannot move to another patient: withdraw it and {again}")


def _article(kind: RecordKind) -> str:
    return f"{'an' if kind.label[0] in 'aeiou' else 'a'} {kind.label}"
