"""The clinical record: versioned create/update/withdraw with optimistic concurrency.

Every write validates the data against its schema, checks references and clinical
times, stores the next version, recomputes the encounter's calculator results and
appends the audit entry, all in one transaction: a rejected write stores nothing.
"""

from __future__ import annotations

import sqlite3

import msgspec

from gateway.services import validation
from gateway.services.assessments import refresh_assessments
from gateway.services.permissions import Principal, readable_kinds, require_delete, require_read, require_write
from gateway.storage import audit
from gateway.storage import records as rows
from gateway.storage.database import Database
from schemas.config import Config
from schemas.errors import Conflict, InvalidInput, VersionMismatch
from schemas.records import ENCOUNTER_PARTS, Record, RecordKind

_encode = msgspec.json.encode


class WriteOutcome(msgspec.Struct, frozen=True):
    record: Record
    created: bool = False
    replayed: bool = False
    """The same write was already stored (a client retry); nothing new was written."""


class RecordService:
    def __init__(self, db: Database, config: Config):
        self.db = db
        self.config = config

    # reads -----------------------------------------------------------------
    def get(self, principal: Principal, kind: RecordKind, record_id: str) -> Record:
        require_read(principal, kind)
        return rows.get_head(self.db.connection(), kind, record_id)

    def history(self, principal: Principal, kind: RecordKind, record_id: str) -> list[Record]:
        require_read(principal, kind)
        return rows.history(self.db.connection(), kind, record_id)

    def list(self, principal: Principal, kind: RecordKind, *, parent_id: str | None = None,
             include_deleted: bool = False, limit: int = 100, offset: int = 0) -> list[Record]:  # fmt: skip
        require_read(principal, kind)
        return rows.list_heads(self.db.connection(), kind, parent_id=parent_id, include_deleted=include_deleted,
                               limit=limit, offset=offset)  # fmt: skip

    def encounter_parts(self, principal: Principal, encounter_id: str) -> dict[RecordKind, Record]:
        with self.db.read() as conn:
            rows.get_head(conn, RecordKind.encounter, encounter_id)
            kinds = ENCOUNTER_PARTS & readable_kinds(principal)
            require_read(principal, RecordKind.encounter)
            return rows.heads_of_children(conn, encounter_id, kinds)

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
            rows.get_head(conn, RecordKind.encounter, encounter_id)
            refresh_assessments(conn, principal, [encounter_id], self.config)
            return rows.get_head(conn, RecordKind.assessment, encounter_id)

    # the same writes inside a caller's transaction (used by sync push) ----------------
    def create_in(self, conn: sqlite3.Connection, principal: Principal, kind: RecordKind, record_id: str,
                  data: object) -> WriteOutcome:  # fmt: skip
        require_write(principal, kind)
        struct = validation.to_struct(kind, data)
        parent_id = validation.check(conn, kind, record_id, struct, self.config)
        data_json = _encode(struct)
        current = rows.find_head(conn, kind, record_id)
        if current is not None:
            if (
                current.meta.version == 1
                and not current.meta.deleted
                and _encode(current.data) == _same(kind, data_json)
            ):
                return WriteOutcome(current, replayed=True)
            raise Conflict(f"a {kind.value.replace('_', ' ')} with id {record_id} already exists with other content",
                           current=current)  # fmt: skip
        record = rows.insert_version(
            conn, kind=kind, record_id=record_id, version=1, parent_id=parent_id, data_json=data_json,
            created_at=None, updated_by=principal.username, device_id=principal.device_id,
        )  # fmt: skip
        audit.append(conn, action="record.create", user_id=principal.user_id, device_id=principal.device_id,
                     kind=kind.value, record_id=record_id, after_version=1)  # fmt: skip
        self._after_write(conn, principal, kind, record_id, struct)
        return WriteOutcome(record, created=True)

    def update_in(self, conn: sqlite3.Connection, principal: Principal, kind: RecordKind, record_id: str,
                  data: object, if_match: int) -> WriteOutcome:  # fmt: skip
        require_write(principal, kind)
        struct = validation.to_struct(kind, data)
        parent_id = validation.check(conn, kind, record_id, struct, self.config)
        data_json = _encode(struct)
        current = rows.get_head(conn, kind, record_id)
        if current.meta.deleted:
            raise Conflict(f"this {kind.value.replace('_', ' ')} was withdrawn ({current.meta.delete_reason})",
                           current=current)  # fmt: skip
        same_content = _encode(current.data) == _same(kind, data_json)
        if current.meta.version != if_match:
            # A retry of the write that made the current version: answer as if it had just succeeded.
            if same_content and if_match == current.meta.version - 1 and current.meta.updated_by == principal.username:
                return WriteOutcome(current, replayed=True)
            raise VersionMismatch(
                f"you edited version {if_match} but the record is now at version {current.meta.version}:"
                " merge with the current version and try again",
                current=current,
            )
        if same_content:
            return WriteOutcome(current, replayed=True)
        record = self._next_version(conn, principal, current, parent_id, data_json)
        audit.append(conn, action="record.update", user_id=principal.user_id, device_id=principal.device_id,
                     kind=kind.value, record_id=record_id, before_version=current.meta.version,
                     after_version=record.meta.version)  # fmt: skip
        self._after_write(conn, principal, kind, record_id, struct)
        return WriteOutcome(record)

    def delete_in(self, conn: sqlite3.Connection, principal: Principal, kind: RecordKind, record_id: str,
                  if_match: int, reason: str) -> WriteOutcome:  # fmt: skip
        require_delete(principal, kind)
        if not reason.strip():
            raise InvalidInput("say why the record is withdrawn (reason)")
        current = rows.get_head(conn, kind, record_id)
        if current.meta.deleted:
            return WriteOutcome(current, replayed=True)
        if current.meta.version != if_match:
            raise VersionMismatch(
                f"you withdrew version {if_match} but the record is now at version {current.meta.version}",
                current=current,
            )
        record = self._next_version(conn, principal, current, _parent_of(current), _encode(current.data),
                                    deleted=True, reason=reason)  # fmt: skip
        audit.append(conn, action="record.delete", user_id=principal.user_id, device_id=principal.device_id,
                     kind=kind.value, record_id=record_id, before_version=current.meta.version,
                     after_version=record.meta.version, detail=reason)  # fmt: skip
        return WriteOutcome(record)

    def _next_version(self, conn, principal, current: Record, parent_id, data_json: bytes, *, deleted=False,
                      reason=None) -> Record:  # fmt: skip
        return rows.insert_version(
            conn, kind=current.meta.kind, record_id=current.meta.id, version=current.meta.version + 1,
            parent_id=parent_id, data_json=data_json, created_at=current.meta.created_at.isoformat(timespec="microseconds"),
            updated_by=principal.username, device_id=principal.device_id, deleted=deleted, delete_reason=reason,
        )  # fmt: skip

    def _after_write(self, conn, principal: Principal, kind: RecordKind, record_id: str, struct) -> None:
        """Recompute the calculator results that depend on what was written."""
        if kind is RecordKind.patient:
            encounters = [
                r.meta.id for r in rows.list_heads(conn, RecordKind.encounter, parent_id=record_id, limit=10_000)
            ]
        else:
            encounters = [record_id]
        refresh_assessments(conn, principal, encounters, self.config)


def _same(kind: RecordKind, data_json: bytes) -> bytes:
    """Stored data round-trips through a dict; compare in that same form."""
    return _encode(msgspec.json.decode(data_json))


def _parent_of(record: Record) -> str | None:
    if record.meta.kind is RecordKind.encounter:
        return record.data.get("patient_id")
    if record.meta.kind is RecordKind.patient:
        return None
    return record.meta.id
