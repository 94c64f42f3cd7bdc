"""Stable identifiers and times: UIDs derived from record ids, the PatientID by the configured rule, dates and
times in the encounter's own zone with TimezoneOffsetFromUTC."""

from __future__ import annotations

import datetime as dt
import uuid

from processing.dicom.inputs import StudyInput
from schemas.dicom import PatientIdRule

NAMESPACE = uuid.UUID("6f1c3c5e-3a6e-5b7e-9a43-2b0d6c1f4e21")
"""burnedge's own namespace for uuid5: changing it would give every exported object a new UID."""


def uid(kind: str, record_id: str, role: str) -> str:
    """A UID under the 2.25 root (PS3.5 B.2: a UUID as a decimal integer) from the record and what the object
    is, so exporting the same record again gives the same UID: a PACS replaces or ignores it, never doubles it."""
    return f"2.25.{uuid.uuid5(NAMESPACE, f'{kind}/{record_id}/{role}').int}"


def patient_id(study: StudyInput) -> str:
    """Never empty: the record number when the rule allows and one was keyed, else the prefix and the record id
    (at most 64 characters, the LO limit)."""
    number = (study.patient.medical_record_number or "").strip()
    if study.patient_id_rule is PatientIdRule.record_number and number:
        return number[:64]
    return f"{study.patient_id_prefix}{study.patient.id}"[:64]


def patient_name(study: StudyInput) -> str:
    """Family^Given; an unknown patient's temporary label as the family name component."""
    p = study.patient
    if p.family_name or p.given_name:
        return f"{person_name(p.family_name)}^{person_name(p.given_name)}"
    return one_name(p.temporary_label or "")


def person_name(text: str) -> str:
    return text.replace("^", " ").replace("=", " ").replace("\\", " ").strip()[:64]


def one_name(text: str) -> str:
    """A name kept as typed, as the family name component: the caret says it is one (PS3.5 6.2.1.2), not the
    retired single-component form."""
    name = person_name(text)
    return f"{name}^" if name else ""


def zone(study: StudyInput) -> dt.tzinfo:
    """The encounter's own zone (its arrival time's offset): every time in the study is written in it."""
    tz = study.encounter.time_of_arrival.tzinfo
    return tz if tz is not None else dt.UTC


def offset(study: StudyInput) -> str:
    """TimezoneOffsetFromUTC, "+HHMM"."""
    return study.encounter.time_of_arrival.astimezone(zone(study)).strftime("%z")


def da(study: StudyInput, moment: dt.datetime) -> str:
    return moment.astimezone(zone(study)).strftime("%Y%m%d")


def tm(study: StudyInput, moment: dt.datetime) -> str:
    return moment.astimezone(zone(study)).strftime("%H%M%S")


def dt_value(study: StudyInput, moment: dt.datetime) -> str:
    """A DT with its offset (PS3.5 6.2), e.g. 20261113051500+0100."""
    return moment.astimezone(zone(study)).strftime("%Y%m%d%H%M%S%z")


def parse_iso(text: str | None) -> dt.datetime | None:
    """An aware datetime from the record's ISO 8601 text; None when absent or without an offset."""
    if not text:
        return None
    try:
        moment = dt.datetime.fromisoformat(text)
    except ValueError:
        return None
    return moment if moment.tzinfo is not None else None
