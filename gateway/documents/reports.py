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

import msgspec

from base.accounts.permissions import Principal, require_read
from base.folders import reports_root
from base.storage import audit
from base.storage import records as store
from base.storage.durable import fsync_dir, replace_atomically
from gateway.records import assessments, decision_support
from gateway.records.snapshot import read_snapshot, with_decision_support
from processing.report.document import render
from processing.report.inputs import REPORT_FORMAT, versions_digest
from schemas.base import utcnow
from schemas.clinical_results import FluidPhase, FluidPlan
from schemas.config import Config
from schemas.encounter_snapshot import EncounterSnapshot
from schemas.errors import Conflict
from schemas.records import RecordKind

REPORT_KINDS = (RecordKind.encounter, RecordKind.patient, RecordKind.burn_analysis, RecordKind.consultation)


@dataclass(frozen=True)
class MadeReport:
    pdf: bytes
    etag: str
    """The cache key: the record versions (and the clock minute while fluids run)."""
    path: Path
    made: bool
    """False when the stored report of the same versions was served."""


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
        """Every record version the encounter's report reads, in one transaction with its decision support brought
        up to date (a withdrawn encounter is a Conflict)."""
        with self.db.write() as conn:
            encounter = store.get_head(conn, RecordKind.encounter, encounter_id)
            if encounter.meta.deleted:
                raise Conflict("this encounter was withdrawn: no report is made of it", current=encounter)
            snapshot = read_snapshot(conn, self.config, encounter_id, utcnow(), made_by)
            support = decision_support.refresh_from(conn, None, snapshot)
            snapshot = with_decision_support(conn, snapshot, support)
            fluids = _fluids_now(conn, self.config, encounter_id, snapshot.made_at) if snapshot.assessment else None
        return msgspec.structs.replace(snapshot, fluids_now=fluids)

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
