"""The clinical record: versioned create/update/withdraw/restore with optimistic concurrency.

Every write validates the data against its schema, checks references and clinical
times, stores the next version, recomputes the encounter's calculator results and
appends the audit entry, all in one transaction: a rejected write stores nothing.
"""

from __future__ import annotations

import sqlite3
from collections.abc import Callable, Mapping

import msgspec

from base.accounts.permissions import (
    Principal,
    check_field_rules,
    readable_kinds,
    require_delete,
    require_read,
    require_write,
)
from base.storage import records as store
from gateway.records import validation
from gateway.records.assessments import refresh_assessments
from gateway.records.snapshot import SNAPSHOT_KINDS, current_snapshot
from gateway.records.versions import write_version
from gateway.storage.database import Database
from schemas.config import Config
from schemas.encounter_snapshot import EncounterSnapshot
from schemas.errors import Conflict, InvalidInput, VersionMismatch
from schemas.records import ENCOUNTER_PARTS, PATIENT_RECORDS, EncounterRecord, Record, RecordKind

_encode = msgspec.json.encode
RESULT_INPUTS = ENCOUNTER_PARTS | {RecordKind.patient, RecordKind.encounter}
"""Kinds whose writes change an encounter's calculator results."""

RecordCheck = Callable[[sqlite3.Connection, str, msgspec.Struct, Config], tuple[msgspec.Struct, str | None]]
"""A domain package's checks of its kind before a write (gateway/wounds/rules.py): given the connection, the record's
id and its validated struct, the struct to store (defaults filled in) and its parent's id; raises InvalidInput or
NotFound when it cannot be stored. The composition root hands them in, so the record service never imports a domain
package."""


class WriteOutcome(msgspec.Struct, frozen=True):
    record: Record
    created: bool = False
    replayed: bool = False
    """The same write was already stored (a client retry); nothing new was written."""


class RecordService:
    def __init__(self, db: Database, config: Config, checks: Mapping[RecordKind, RecordCheck] | None = None):
        self.db = db
        self.config = config
        self.checks = dict(checks or {})
        """The domain packages' checks, by the kind they keep (gateway.dependencies.Services.build hands them in)."""

    # reads -----------------------------------------------------------------
    def get(self, principal: Principal, kind: RecordKind, record_id: str) -> Record:
        require_read(principal, kind)
        return store.get_head(self.db.connection(), kind, record_id)

    def history(self, principal: Principal, kind: RecordKind, record_id: str) -> list[Record]:
        require_read(principal, kind)
        return store.history(self.db.connection(), kind, record_id)

    def list_records(
        self,
        principal: Principal,
        kind: RecordKind,
        *,
        parent_id: str | None = None,
        include_deleted: bool = False,
        limit: int = 100,
        offset: int = 0,
    ) -> list[Record]:
        require_read(principal, kind)
        if limit is not None:
            limit = min(limit, self.config.gateway.page_max)
        return store.list_heads(
            self.db.connection(), kind, parent_id=parent_id, include_deleted=include_deleted, limit=limit, offset=offset
        )

    def encounter_record(self, principal: Principal, encounter_id: str) -> EncounterRecord:
        require_read(principal, RecordKind.encounter)
        kinds = ENCOUNTER_PARTS & readable_kinds(principal)
        with self.db.read() as conn:
            encounter = store.get_head(conn, RecordKind.encounter, encounter_id)
            return EncounterRecord(encounter=encounter, parts=store.heads_of_children(conn, encounter_id, kinds))

    def snapshot(self, principal: Principal, encounter_id: str) -> EncounterSnapshot:
        """The encounter as it stands now, in one reading (decision support as last stored): what its pages show."""
        for kind in SNAPSHOT_KINDS:
            require_read(principal, kind)
        return current_snapshot(self.db, self.config, encounter_id, principal.username)

    # writes --------------------------------------------------------------------
    def create(self, principal: Principal, kind: RecordKind, record_id: str, data: object) -> WriteOutcome:
        with self.db.write() as conn:
            return self.create_in(conn, principal, kind, record_id, data)

    def update(
        self, principal: Principal, kind: RecordKind, record_id: str, data: object, if_match: int
    ) -> WriteOutcome:
        with self.db.write() as conn:
            return self.update_in(conn, principal, kind, record_id, data, if_match)

    def delete(
        self, principal: Principal, kind: RecordKind, record_id: str, if_match: int, reason: str
    ) -> WriteOutcome:
        with self.db.write() as conn:
            return self.delete_in(conn, principal, kind, record_id, if_match, reason)

    def recompute_assessment(self, principal: Principal, encounter_id: str) -> Record:
        require_read(principal, RecordKind.assessment)
        require_write(principal, RecordKind.intake)  # anyone who may document may refresh the results
        with self.db.write() as conn:
            encounter = store.get_head(conn, RecordKind.encounter, encounter_id)
            if encounter.meta.deleted:
                raise Conflict("this encounter was withdrawn: its results are no longer recomputed", current=encounter)
            refresh_assessments(conn, principal, [encounter_id], self.config)
            return store.get_head(conn, RecordKind.assessment, encounter_id)

    # the same writes inside a caller's transaction (used by sync push) ----------------
    def create_in(
        self, conn: sqlite3.Connection, principal: Principal, kind: RecordKind, record_id: str, data: object
    ) -> WriteOutcome:
        require_write(principal, kind)
        struct, parent_id = self._checked(conn, kind, record_id, data)
        check_field_rules(principal, kind, struct, None)
        data_json = _encode(struct)
        current = store.find_head(conn, kind, record_id)
        if current is not None:
            if current.meta.deleted:
                raise Conflict(
                    f"this {kind.label} was withdrawn ({current.meta.delete_reason}): to restore it, update it with"
                    f' If-Match: "{current.meta.version}"',
                    current=current,
                )
            if current.meta.version == 1 and _same_content(current, data_json):
                return WriteOutcome(current, replayed=True)
            raise Conflict(f"a {kind.label} with id {record_id} already exists with other content", current=current)
        record = write_version(conn, principal, kind, record_id, 1, parent_id, data_json, None, "record.create")
        self._refresh_results(conn, principal, kind, record_id)
        return WriteOutcome(record, created=True)

    def update_in(
        self,
        conn: sqlite3.Connection,
        principal: Principal,
        kind: RecordKind,
        record_id: str,
        data: object,
        if_match: int,
    ) -> WriteOutcome:
        """Update to a new version; on a withdrawn record, If-Match of the withdrawn version restores it."""
        require_write(principal, kind)
        struct, parent_id = self._checked(conn, kind, record_id, data)
        data_json = _encode(struct)
        current = store.get_head(conn, kind, record_id)
        check_field_rules(principal, kind, struct, current)
        validation.check_unchanged_links(kind, struct, current)
        same_content = _same_content(current, data_json)
        if current.meta.version != if_match:
            # A retry of the write that made the current version: answer as if it had just succeeded.
            if (
                same_content
                and not current.meta.deleted
                and if_match == current.meta.version - 1
                and current.meta.updated_by == principal.username
            ):
                return WriteOutcome(current, replayed=True)
            raise VersionMismatch(
                f"you edited version {if_match} but the record is now at version {current.meta.version}:"
                " merge with the current version and try again",
                current=current,
            )
        if same_content and not current.meta.deleted:
            return WriteOutcome(current, replayed=True)
        action = "record.restore" if current.meta.deleted else "record.update"
        record = write_version(
            conn, principal, kind, record_id, current.meta.version + 1, parent_id, data_json, current, action
        )
        self._refresh_results(conn, principal, kind, record_id)
        return WriteOutcome(record)

    def delete_in(
        self,
        conn: sqlite3.Connection,
        principal: Principal,
        kind: RecordKind,
        record_id: str,
        if_match: int,
        reason: str,
    ) -> WriteOutcome:
        require_delete(principal, kind)
        if not reason.strip():
            raise InvalidInput("say why the record is withdrawn (reason)")
        current = store.get_head(conn, kind, record_id)
        if current.meta.deleted:
            return WriteOutcome(current, replayed=True)
        if current.meta.version != if_match:
            raise VersionMismatch(
                f"you withdrew version {if_match} but the record is now at version {current.meta.version}",
                current=current,
            )
        record = write_version(
            conn,
            principal,
            kind,
            record_id,
            current.meta.version + 1,
            _parent_of(current),
            _encode(current.data),
            current,
            "record.delete",
            reason=reason,
        )
        if kind in ENCOUNTER_PARTS:
            self._refresh_results(conn, principal, kind, record_id)
        return WriteOutcome(record)

    def _checked(
        self, conn: sqlite3.Connection, kind: RecordKind, record_id: str, data: object
    ) -> tuple[msgspec.Struct, str | None]:
        """The struct to store and its parent's id, once the record passed its checks."""
        struct = validation.to_struct(kind, data)
        check = self.checks.get(kind)
        if check is not None:
            return check(conn, record_id, struct, self.config)
        return struct, validation.check(conn, kind, record_id, struct, self.config)

    def _refresh_results(self, conn, principal: Principal, kind: RecordKind, record_id: str) -> None:
        """Recompute the calculator results that depend on what was written."""
        if kind not in RESULT_INPUTS:
            return
        if kind is RecordKind.patient:
            encounters = [
                r.meta.id for r in store.list_heads(conn, RecordKind.encounter, parent_id=record_id, limit=None)
            ]
        else:
            encounters = [record_id]
        refresh_assessments(conn, principal, encounters, self.config)


def _same_content(current: Record, data_json: bytes) -> bool:
    """Stored data round-trips through a dict; compare in that same form."""
    return _encode(current.data) == _encode(msgspec.json.decode(data_json))


def _parent_of(record: Record) -> str | None:
    if record.meta.kind in PATIENT_RECORDS:
        return record.value().patient_id
    if record.meta.kind is RecordKind.patient:
        return None
    return record.meta.id
