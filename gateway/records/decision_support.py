"""Stores each encounter's decision support with the record versions it read, and clinicians' acts on it.

Recomputed in the transaction of every write that can change it (a record part, a finished analysis), and when a
report is made (the cooling window and the days since injury move with the clock). A new version is written
only when the advice changed; acts are carried over as processing/clinical/decision_support.py says.
"""

from __future__ import annotations

import datetime as dt
import sqlite3

import msgspec

from base.accounts.permissions import Principal, require_decide, require_read, require_write
from base.storage import records as store
from gateway.jobs import timeline
from gateway.records.computed import store_computed
from gateway.storage import jobs
from processing.clinical import decision_support as rules
from processing.clinical.decision_inputs import DecisionInputs, Versioned, WoundTrack
from schemas.base import utcnow
from schemas.clinical_results import InputRef
from schemas.config import Config
from schemas.decision_support import DecisionSupport, RecommendationAct
from schemas.errors import Conflict, NotFound, VersionMismatch
from schemas.longitudinal import TrackResult
from schemas.records import RECORD_TYPES, Record, RecordKind

KIND = RecordKind.decision_support
_PARTS = {
    RecordKind.intake: "intake",
    RecordKind.primary_survey: "primary",
    RecordKind.secondary_survey: "secondary",
    RecordKind.mechanism: "mechanism",
    RecordKind.burn_chart: "chart",
    RecordKind.resuscitation: "resuscitation",
    RecordKind.assessment: "assessment",
}


def versioned(record: Record) -> Versioned:
    value = msgspec.convert(record.data, RECORD_TYPES[record.meta.kind])
    return Versioned(value, InputRef(kind=record.meta.kind.value, id=record.meta.id, version=record.meta.version))


def _tracks(conn: sqlite3.Connection, config: Config, patient_id: str) -> list[WoundTrack]:
    """Each wound's stored track (and one for analyses of no wound), with the analyses it was made from."""
    heads = store.list_heads(conn, RecordKind.wound, parent_id=patient_id, limit=None)
    wounds: list[tuple[str | None, str]] = [(w.meta.id, w.value().label) for w in heads if not w.meta.deleted]
    if any(job.wound_id is None for job in jobs.measured(conn, patient_id)):
        wounds.append((None, "burn"))
    out = []
    for wound_id, label in wounds:
        path = timeline.track_path(conn, config, patient_id, wound_id)
        if path is None:
            continue
        track = msgspec.json.decode(path.read_bytes(), type=TrackResult)
        refs = []
        for session in track.sessions:
            job_id = timeline.job_of(session.analysis)
            head = store.find_head(conn, RecordKind.burn_analysis, job_id)
            if head is not None:
                refs.append(InputRef(kind=head.meta.kind.value, id=job_id, version=head.meta.version))
        out.append(WoundTrack(label=label, track=track, refs=refs, wound_id=wound_id))
    return out


def gather(conn: sqlite3.Connection, config: Config, encounter_id: str, as_of: dt.datetime) -> DecisionInputs:
    """What the rules read, from the current versions of the encounter's record."""
    encounter = store.get_head(conn, RecordKind.encounter, encounter_id)
    patient = store.get_head(conn, RecordKind.patient, encounter.value().patient_id)
    heads = store.heads_of_children(conn, encounter_id, _PARTS)
    parts = {_PARTS[kind]: versioned(r) for kind, r in heads.items() if not r.meta.deleted}
    assessment = parts.get("assessment")
    analyses = [
        versioned(r)
        for r in store.list_heads(conn, RecordKind.burn_analysis, parent_id=encounter_id, limit=None)
        if not r.meta.deleted
    ]
    return DecisionInputs(
        patient=versioned(patient),
        encounter=versioned(encounter),
        as_of=as_of,
        age_years=assessment.value.age_years if assessment else None,
        analyses=analyses,
        tracks=_tracks(conn, config, patient.meta.id),
        **parts,
    )


def refresh(conn: sqlite3.Connection, principal: Principal | None, encounter_id: str, config: Config) -> Record:
    """Recompute the encounter's decision support as of now; store a new version if the advice changed."""
    now = utcnow()
    fresh = rules.recommend(gather(conn, config, encounter_id, now), computed_at=now)
    current = store.find_head(conn, KIND, encounter_id)
    previous = msgspec.convert(current.data, DecisionSupport) if current else None
    result = rules.carry_over(previous, fresh)
    if previous is not None and rules.same_advice(previous, result):
        return current
    return store_computed(conn, principal, KIND, encounter_id, result, current, "decision_support.compute")


def record_act(conn: sqlite3.Connection, principal: Principal, encounter_id: str, act, if_match: int) -> Record:
    """One recommendation accepted or declined, as the next version of the record (If-Match: its version)."""
    current = store.find_head(conn, KIND, encounter_id)
    if current is None:
        raise NotFound(f"encounter {encounter_id} has no decision support yet")
    if current.meta.version != if_match:
        raise VersionMismatch(
            f"you acted on version {if_match} of the recommendations but they are now at version "
            f"{current.meta.version}: read them again (the advice may have changed)",
            current=current,
        )
    data = rules.apply_act(msgspec.convert(current.data, DecisionSupport), act, principal.username, utcnow())
    detail = f"{act.key}: {act.state}" + (f": {act.reason.strip()}" if act.reason.strip() else "")
    return store_computed(conn, principal, KIND, encounter_id, data, current, f"recommendation.{act.state}", detail)


def refresh_patient(db, config: Config, patient_id: str) -> None:
    """After an analysis of the patient: every live encounter's decision support (the healing prompts moved)."""
    with db.write() as conn:
        for encounter in store.list_heads(conn, RecordKind.encounter, parent_id=patient_id, limit=None):
            if not encounter.meta.deleted:
                refresh(conn, None, encounter.meta.id, config)


class DecisionSupportService:
    def __init__(self, db, config: Config):
        self.db = db
        self.config = config

    def get(self, principal: Principal, encounter_id: str) -> Record:
        require_read(principal, KIND)
        conn = self.db.connection()
        store.get_head(conn, RecordKind.encounter, encounter_id)
        head = store.find_head(conn, KIND, encounter_id)
        if head is None:
            raise NotFound(f"encounter {encounter_id} has no decision support yet: record its intake or burn chart")
        return head

    def recompute(self, principal: Principal, encounter_id: str) -> Record:
        """As of now: the cooling window and the days since injury move with the clock."""
        require_read(principal, KIND)
        require_write(principal, RecordKind.intake)
        with self.db.write() as conn:
            encounter = store.get_head(conn, RecordKind.encounter, encounter_id)
            if encounter.meta.deleted:
                raise Conflict("this encounter was withdrawn: its decision support is no longer recomputed")
            return refresh(conn, principal, encounter_id, self.config)

    def act(self, principal: Principal, encounter_id: str, act: RecommendationAct, if_match: int) -> Record:
        require_decide(principal)
        with self.db.write() as conn:
            store.get_head(conn, RecordKind.encounter, encounter_id)
            return record_act(conn, principal, encounter_id, act, if_match)
