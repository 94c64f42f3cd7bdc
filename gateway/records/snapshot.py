"""Reads an encounter's snapshot (schemas/encounter_snapshot.py) in the caller's transaction: the one reading that
decision support, the report, the FHIR export, the case bundle and the encounter's pages are all made from."""

from __future__ import annotations

import datetime as dt
import sqlite3

import msgspec

from base import __version__
from base.folders import analysis_dir
from base.storage import audit
from base.storage import records as store
from gateway.jobs.healing import patient_healing
from gateway.storage import jobs
from gateway.storage.database import Database
from schemas.audit import AuditHead
from schemas.base import iso, utcnow
from schemas.config import Config
from schemas.encounter_snapshot import AnalysisVisit, EncounterSnapshot, Versioned
from schemas.ids import uuid7
from schemas.records import Record, RecordKind

PART_FIELDS = {
    RecordKind.intake: "intake",
    RecordKind.primary_survey: "primary",
    RecordKind.secondary_survey: "secondary",
    RecordKind.mechanism: "mechanism",
    RecordKind.burn_chart: "chart",
    RecordKind.resuscitation: "resuscitation",
    RecordKind.assessment: "assessment",
    RecordKind.decision_support: "decision_support",
}
"""Each record part of an encounter and the snapshot's field that holds it."""
SNAPSHOT_KINDS = (
    RecordKind.encounter,
    RecordKind.patient,
    *PART_FIELDS,
    RecordKind.wound,
    RecordKind.burn_analysis,
    RecordKind.consultation,
)
"""Every kind of record a snapshot holds: who reads one must be allowed to read each."""


def read_snapshot(
    conn: sqlite3.Connection, config: Config, encounter_id: str, now: dt.datetime, made_by: str
) -> EncounterSnapshot:
    """Every current version the encounter's documents and pages are made from (withdrawn parts left out)."""
    encounter = store.get_head(conn, RecordKind.encounter, encounter_id)
    patient_id = encounter.value().patient_id
    patient = store.get_head(conn, RecordKind.patient, patient_id)
    heads = store.heads_of_children(conn, encounter_id, PART_FIELDS)
    parts = {PART_FIELDS[kind]: Versioned.of(r) for kind, r in heads.items() if not r.meta.deleted}
    wound_heads = _live(store.list_heads(conn, RecordKind.wound, parent_id=patient_id, limit=None))
    wounds = [Versioned.of(w) for w in wound_heads]
    labels = {w.ref.id: w.value.label for w in wounds}
    visits, own = _analyses(conn, config, patient_id, encounter_id, labels)
    consultations = store.list_heads(conn, RecordKind.consultation, parent_id=encounter_id, limit=None)
    chain = audit.head(conn)
    return EncounterSnapshot(
        snapshot_id=uuid7(),
        made_at=now,
        made_by=made_by,
        software_version=__version__,
        clinic=config.report.clinic_name,
        patient=Versioned.of(patient),
        encounter=Versioned.of(encounter),
        wounds=wounds,
        encounter_analyses=own,
        analyses=visits,
        healing=patient_healing(conn, config, patient_id, wound_heads).wounds,
        consultations=[Versioned.of(c) for c in _live(consultations)],
        audit_head=AuditHead(seq=chain.seq, hash=chain.hash) if chain else None,
        **parts,
    )


def current_snapshot(db: Database, config: Config, encounter_id: str, made_by: str) -> EncounterSnapshot:
    """The encounter as it stands now, read in its own transaction (decision support as last stored)."""
    with db.read() as conn:
        return read_snapshot(conn, config, encounter_id, utcnow(), made_by)


def with_decision_support(conn: sqlite3.Connection, snapshot: EncounterSnapshot, support: Record) -> EncounterSnapshot:
    """The snapshot with the decision support just recomputed from it in this transaction (and the audit chain's
    head after storing it)."""
    chain = audit.head(conn)
    return msgspec.structs.replace(
        snapshot,
        decision_support=Versioned.of(support),
        audit_head=AuditHead(seq=chain.seq, hash=chain.hash) if chain else None,
    )


def _live(records: list[Record]) -> list[Record]:
    return [r for r in records if not r.meta.deleted]


def _analyses(
    conn: sqlite3.Connection, config: Config, patient_id: str, encounter_id: str, labels: dict[str, str]
) -> tuple[list[AnalysisVisit], list[AnalysisVisit]]:
    """(visits, this encounter's): the latest finished analysis of each wound at each of the patient's encounters,
    in the order the photos were taken; and every finished analysis of this encounter, re-runs too, oldest first."""
    visits, own = [], []
    for encounter in _live(store.list_heads(conn, RecordKind.encounter, parent_id=patient_id, limit=None)):
        heads = store.list_heads(conn, RecordKind.burn_analysis, parent_id=encounter.meta.id, limit=None)
        measured = [_visit(conn, config, encounter, head, encounter_id, labels) for head in _live(heads)]
        measured.sort(key=lambda v: (v.analysis.value.completed_at, v.analysis.ref.id))
        latest = {v.wound_id: v for v in measured}  # a re-analysis of a visit replaces the earlier one
        visits += latest.values()
        if encounter.meta.id == encounter_id:
            own = measured
    return sorted(visits, key=lambda v: (v.day is None, v.day or 0.0, v.visit)), own


def _visit(
    conn: sqlite3.Connection, config: Config, encounter: Record, head: Record, encounter_id: str, labels: dict
) -> AnalysisVisit:
    analysis = Versioned.of(head)
    value = analysis.value
    wound_id = _wound_of(conn, head)
    taken = value.captured.at if value.captured else iso(encounter.value().time_of_arrival)
    day = value.result.hours_since_injury / 24 if value.result.hours_since_injury is not None else None
    here = "this encounter" if encounter.meta.id == encounter_id else "visit"
    wound = labels.get(wound_id or "", "")
    label = f"{wound + ', ' if wound else ''}{here}, photos {taken[:16].replace('T', ' ')}"
    label += f", day {day:.0f} after injury" if day else ""
    return AnalysisVisit(analysis, analysis_dir(config, value.job_id), label, day, wound_id=wound_id, wound=wound)


def _wound_of(conn: sqlite3.Connection, analysis: Record) -> str | None:
    """The wound the analysis measured: its own field, else its job's (the upgrade gave older jobs one)."""
    wound_id = analysis.value().wound_id
    if wound_id is None:
        job = jobs.find(conn, analysis.meta.id)
        wound_id = job.wound_id if job is not None else None
    return wound_id
