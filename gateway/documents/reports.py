"""The clinical report of an encounter: made from one snapshot of its record, cached by the versions it read.

A report is made again whenever a record version it reads changes (and, while a fluid plan is running, every
minute: the rate to run now moves with the clock). Each report made enters the audit chain with its id, the
SHA-256 of its bytes and of the record versions; a cached one is served as it was made.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import sqlite3
from dataclasses import dataclass
from pathlib import Path

from base import __version__
from base.accounts.permissions import Principal, require_read
from base.folders import analysis_dir, reports_root
from base.storage import audit
from base.storage import records as store
from base.storage.durable import fsync_dir, replace_atomically
from gateway.records import assessments, decision_support
from gateway.storage import jobs
from gateway.wounds.healing import patient_healing
from processing.report.document import render
from processing.report.inputs import REPORT_FORMAT, versions_digest
from processing.snapshot import AnalysisVisit, EncounterSnapshot
from schemas.audit import AuditHead
from schemas.base import iso, utcnow
from schemas.clinical_results import FluidPhase, FluidPlan
from schemas.config import Config
from schemas.errors import Conflict
from schemas.ids import uuid7
from schemas.jobs import BurnAnalysis
from schemas.records import Record, RecordKind

REPORT_KINDS = (RecordKind.encounter, RecordKind.patient, RecordKind.burn_analysis, RecordKind.consultation)


@dataclass(frozen=True)
class MadeReport:
    pdf: bytes
    etag: str
    """The cache key: the record versions (and the clock minute while fluids run)."""
    path: Path
    made: bool
    """False when the stored report of the same versions was served."""


def _visits(
    conn: sqlite3.Connection, config: Config, patient_id: str, encounter_id: str, labels: dict[str, str]
) -> list[AnalysisVisit]:
    """The latest finished analysis of each wound at each of the patient's encounters, in the order the photos were
    taken."""
    pages = []
    for encounter in store.list_heads(conn, RecordKind.encounter, parent_id=patient_id, limit=None):
        if encounter.meta.deleted:
            continue
        latest: dict[str | None, Record] = {}
        heads = store.list_heads(conn, RecordKind.burn_analysis, parent_id=encounter.meta.id, limit=None)
        for head in sorted(heads, key=lambda r: r.value().completed_at):
            latest[_wound_of(conn, head)] = head
        for wound_id, head in latest.items():
            analysis = decision_support.versioned(head)
            value: BurnAnalysis = analysis.value
            taken = value.captured.at if value.captured else iso(encounter.value().time_of_arrival)
            day = value.result.hours_since_injury / 24 if value.result.hours_since_injury is not None else None
            here = "this encounter" if encounter.meta.id == encounter_id else "visit"
            wound = labels.get(wound_id or "", "")
            label = f"{wound + ', ' if wound else ''}{here}, photos {taken[:16].replace('T', ' ')}"
            label += f", day {day:.0f} after injury" if day else ""
            folder = analysis_dir(config, value.job_id)
            pages.append(AnalysisVisit(analysis, folder, label, day, wound_id=wound_id, wound=wound))
    return sorted(pages, key=lambda p: (p.day is None, p.day or 0.0, p.visit))


def _wound_of(conn: sqlite3.Connection, analysis: Record) -> str | None:
    """The wound the analysis measured: its own field, else its job's (the upgrade gave older jobs one)."""
    wound_id = analysis.value().wound_id
    if wound_id is None:
        job = jobs.find(conn, analysis.meta.id)
        wound_id = job.wound_id if job is not None else None
    return wound_id


def _fluids_now(conn: sqlite3.Connection, config: Config, encounter_id: str, now: dt.datetime) -> FluidPlan | None:
    return assessments.compute(conn, encounter_id, config, now).fluids


class ReportService:
    def __init__(self, db, config: Config):
        self.db = db
        self.config = config

    def make(self, principal: Principal | None, encounter_id: str, made_by: str = "") -> MadeReport:
        """The report as of now (principal None: the gateway itself, e.g. for a case bundle)."""
        if principal is not None:
            for kind in REPORT_KINDS:
                require_read(principal, kind)
        inputs = self.current(encounter_id, made_by or (principal.username if principal else "gateway"))
        return self.make_from(principal, inputs)

    def current(self, encounter_id: str, made_by: str) -> EncounterSnapshot:
        """Decision support brought up to date, then every record version the encounter's report reads, in one
        snapshot (a withdrawn encounter is a Conflict)."""
        with self.db.write() as conn:
            encounter = store.get_head(conn, RecordKind.encounter, encounter_id)
            if encounter.meta.deleted:
                raise Conflict("this encounter was withdrawn: no report is made of it", current=encounter)
            decision_support.refresh(conn, None, encounter_id, self.config)
        with self.db.read() as conn:
            return self.snapshot(conn, encounter_id, utcnow(), made_by)

    def make_from(self, principal: Principal | None, inputs: EncounterSnapshot) -> MadeReport:
        """The report of exactly this snapshot (the stored one when the same versions were reported before)."""
        encounter_id = inputs.encounter.value.id
        now = inputs.made_at
        running = inputs.fluids_now is not None and inputs.fluids_now.phase is not FluidPhase.complete
        versions = versions_digest(inputs.refs())
        key = hashlib.sha256(f"{versions} {now:%Y-%m-%dT%H:%M}".encode()).hexdigest() if running else versions
        folder = reports_root(self.config) / encounter_id
        path = folder / f"{key}.pdf"
        if path.is_file():
            return MadeReport(path.read_bytes(), f'"{key}"', path, made=False)
        pdf = render(inputs)
        folder.mkdir(parents=True, exist_ok=True)
        replace_atomically(path, pdf)
        fsync_dir(folder)
        with self.db.write() as conn:
            audit.append(
                conn,
                action="report.make",
                user_id=principal.user_id if principal else None,
                device_id=principal.device_id if principal else None,
                kind=RecordKind.encounter.value,
                record_id=encounter_id,
                detail=f"report {inputs.report_id} ({REPORT_FORMAT}): pdf sha256 {hashlib.sha256(pdf).hexdigest()}, "
                f"record versions sha256 {versions}",
            )
        return MadeReport(pdf, f'"{key}"', path, made=True)

    def snapshot(
        self, conn: sqlite3.Connection, encounter_id: str, now: dt.datetime, made_by: str
    ) -> EncounterSnapshot:
        """Every record version a report (or the FHIR export) of the encounter is made from, read in one go."""
        gathered = decision_support.gather(conn, self.config, encounter_id, now)
        head = store.find_head(conn, RecordKind.decision_support, encounter_id)
        consultations = store.list_heads(conn, RecordKind.consultation, parent_id=encounter_id, limit=None)
        chain = audit.head(conn)
        patient_id = gathered.patient.value.id
        wound_heads = [w for w in store.list_heads(conn, RecordKind.wound, parent_id=patient_id, limit=None)]
        wounds = [decision_support.versioned(w) for w in wound_heads if not w.meta.deleted]
        return EncounterSnapshot(
            report_id=uuid7(),
            made_at=now,
            made_by=made_by,
            software_version=__version__,
            clinic=self.config.report.clinic_name,
            patient=gathered.patient,
            encounter=gathered.encounter,
            intake=gathered.intake,
            primary=gathered.primary,
            secondary=gathered.secondary,
            mechanism=gathered.mechanism,
            chart=gathered.chart,
            resuscitation=gathered.resuscitation,
            assessment=gathered.assessment,
            fluids_now=_fluids_now(conn, self.config, encounter_id, now) if gathered.assessment else None,
            decision_support=decision_support.versioned(head) if head else None,
            wounds=wounds,
            analyses=_visits(conn, self.config, patient_id, encounter_id, {w.ref.id: w.value.label for w in wounds}),
            healing=patient_healing(self.db, self.config, patient_id, wound_heads).wounds,
            consultations=[decision_support.versioned(c) for c in consultations if not c.meta.deleted],
            audit_head=AuditHead(seq=chain.seq, hash=chain.hash) if chain else None,
        )
