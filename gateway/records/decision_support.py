"""Stores each encounter's decision support with the record versions it read, and clinicians' acts on it.

Recomputed in the transaction of every write that can change it (a record part, a finished analysis), and when a
report is made (the cooling window and the days since injury move with the clock). A new version is written
only when the advice changed; acts are carried over as processing/clinical/decision_support.py says.
"""

from __future__ import annotations

import sqlite3

import msgspec

from base.accounts.permissions import Principal, require_decide, require_read, require_write
from base.storage import records as store
from gateway.records.computed import store_computed
from gateway.records.snapshot import read_snapshot
from processing.clinical import decision_support as rules
from processing.clinical.decision_inputs import decision_inputs
from schemas.base import utcnow
from schemas.config import Config
from schemas.decision_support import DecisionSupport, RecommendationAct
from schemas.encounter_snapshot import EncounterSnapshot
from schemas.errors import Conflict, NotFound, VersionMismatch
from schemas.records import Record, RecordKind

KIND = RecordKind.decision_support


def refresh(conn: sqlite3.Connection, principal: Principal | None, encounter_id: str, config: Config) -> Record:
    """Recompute the encounter's decision support as of now; store a new version if the advice changed."""
    snapshot = read_snapshot(conn, config, encounter_id, utcnow(), principal.username if principal else "gateway")
    return refresh_from(conn, principal, snapshot)


def refresh_from(conn: sqlite3.Connection, principal: Principal | None, snapshot: EncounterSnapshot) -> Record:
    """Decision support recomputed from a snapshot read in this transaction, as of its reading; a new version is
    stored only if the advice changed."""
    now = snapshot.made_at
    fresh = rules.recommend(decision_inputs(snapshot), computed_at=now)
    encounter_id = snapshot.encounter.value.id
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
