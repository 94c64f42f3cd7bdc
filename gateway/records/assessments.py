"""Runs the clinical calculators server-side and stores their results with their inputs."""

from __future__ import annotations

import sqlite3

import msgspec

from base.accounts.permissions import Principal
from base.storage import records as store
from gateway.records import decision_support
from gateway.records.computed import store_computed
from processing.clinical.assessment import assess
from schemas.base import utcnow
from schemas.clinical_results import Assessment, InputRef
from schemas.config import Config
from schemas.records import COMPUTED_PARTS, ENCOUNTER_PARTS, RECORD_TYPES, Record, RecordKind

_INPUT_PARTS = ENCOUNTER_PARTS - COMPUTED_PARTS


def _struct(record: Record):
    return msgspec.convert(record.data, RECORD_TYPES[record.meta.kind])


def compute(conn: sqlite3.Connection, encounter_id: str, config: Config, now) -> Assessment:
    """The encounter's Assessment as of `now`, from the current versions of its record (nothing stored)."""
    encounter = store.get_head(conn, RecordKind.encounter, encounter_id)
    patient = store.get_head(conn, RecordKind.patient, encounter.value().patient_id)
    parts = {k: r for k, r in store.heads_of_children(conn, encounter_id, _INPUT_PARTS).items() if not r.meta.deleted}
    used = [patient, encounter, *parts.values()]
    return assess(
        patient=_struct(patient),
        encounter=_struct(encounter),
        parts={kind: _struct(r) for kind, r in parts.items()},
        inputs=[InputRef(kind=r.meta.kind.value, id=r.meta.id, version=r.meta.version) for r in used],
        as_of=now,
        config=config.clinical,
        computed_at=now,
        clock_skew_s=config.gateway.clock_skew_s,
    )


def refresh_assessments(
    conn: sqlite3.Connection, principal: Principal, encounter_ids: list[str], config: Config
) -> None:
    """Recompute and store each encounter's Assessment as of now. Inside the caller's transaction."""
    for encounter_id in encounter_ids:
        encounter = store.find_head(conn, RecordKind.encounter, encounter_id)
        if encounter is None or encounter.meta.deleted:
            continue
        result = compute(conn, encounter_id, config, utcnow())
        current = store.find_head(conn, RecordKind.assessment, encounter_id)
        store_computed(conn, principal, RecordKind.assessment, encounter_id, result, current, "assessment.compute")
        decision_support.refresh(conn, principal, encounter_id, config)
