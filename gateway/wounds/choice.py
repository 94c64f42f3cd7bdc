"""Which wound an analysis or a picture belongs to, checked against the patient's live wounds."""

from __future__ import annotations

import sqlite3

from base.storage import records as store
from gateway.records.validation import bad_field
from schemas.records import Record, RecordKind
from schemas.wound import WoundState

NOT_CLOSED = (WoundState.open, WoundState.healing)


def live_wounds(conn: sqlite3.Connection, patient_id: str) -> list[Record]:
    """The patient's wounds that are not withdrawn, oldest first."""
    return [w for w in store.list_heads(conn, RecordKind.wound, parent_id=patient_id, limit=None) if not w.meta.deleted]


def wound_of_patient(conn: sqlite3.Connection, patient_id: str, wound_id: str, field: str) -> Record:
    """The live wound `wound_id` of this patient; 422 naming the field when it is not one."""
    wound = store.find_head(conn, RecordKind.wound, wound_id)
    if wound is None or wound.value().patient_id != patient_id:
        raise bad_field(field, f"{wound_id} is not a wound of this patient: {_listed(live_wounds(conn, patient_id))}")
    if wound.meta.deleted:
        raise bad_field(field, f"the wound {wound.value().label!r} was withdrawn ({wound.meta.delete_reason})")
    return wound


def wound_of_analysis(conn: sqlite3.Connection, patient_id: str, wound_id: str | None) -> Record | None:
    """The wound an analysis measures: the one named; else the patient's only wound, or only wound not closed; None
    for a patient with no wound recorded. 422 naming the wounds when the patient has several open ones."""
    if wound_id is not None:
        return wound_of_patient(conn, patient_id, wound_id, "$.wound_id")
    wounds = live_wounds(conn, patient_id)
    if len(wounds) <= 1:
        return wounds[0] if wounds else None
    open_ = [w for w in wounds if w.value().state in NOT_CLOSED]
    if len(open_) == 1:
        return open_[0]
    raise bad_field(
        "$.wound_id",
        f"the patient has {len(open_) or len(wounds)} wounds: say which one this analysis measures (wound_id): "
        + _listed(open_ or wounds),
    )


def _listed(wounds: list[Record]) -> str:
    if not wounds:
        return "the patient has no wound recorded"
    return "; ".join(f"{w.value().label} ({w.meta.id})" for w in wounds)
