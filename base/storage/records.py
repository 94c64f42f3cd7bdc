"""Row-level access to versioned records. Knows SQL, not clinical rules.

A change never rewrites a row: it inserts the next version into record_versions and
moves the record's head. Soft deletes are versions too, so history stays readable.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import json
import sqlite3
from collections.abc import Iterable

import msgspec

from schemas.base import iso, utcnow
from schemas.errors import NotFound
from schemas.records import Record, RecordKind, RecordMeta
from schemas.sync import MutationResult

_COLUMNS = (
    "v.seq, v.kind, v.id, v.version, v.parent_id, v.data, v.deleted, v.delete_reason, "
    "v.created_at, v.updated_at, v.updated_by, v.device_id"
)
_decode = msgspec.json.Decoder(dict).decode


def version_content_hash(data_text: str, deleted: bool, delete_reason: str | None) -> str:
    """What the audit trail remembers of a stored version, to detect later edits."""
    canonical = json.dumps([data_text, deleted, delete_reason], separators=(",", ":"), ensure_ascii=False)
    return hashlib.sha256(canonical.encode("utf-8")).hexdigest()


def row_to_record(row: sqlite3.Row) -> Record:
    meta = RecordMeta(
        kind=RecordKind(row["kind"]),
        id=row["id"],
        version=row["version"],
        created_at=_parse_time(row["created_at"]),
        updated_at=_parse_time(row["updated_at"]),
        updated_by=row["updated_by"],
        device_id=row["device_id"],
        deleted=bool(row["deleted"]),
        delete_reason=row["delete_reason"],
        seq=row["seq"],
    )
    return Record(meta=meta, data=_decode(row["data"]))


def _parse_time(text: str) -> dt.datetime:
    return dt.datetime.fromisoformat(text)


def find_head(conn: sqlite3.Connection, kind: RecordKind, record_id: str) -> Record | None:
    """The current version, or None when the record was never created."""
    row = conn.execute(
        f"SELECT {_COLUMNS} FROM record_heads h JOIN record_versions v ON v.seq = h.seq WHERE h.kind = ? AND h.id = ?",
        (kind.value, record_id),
    ).fetchone()
    return row_to_record(row) if row else None


def get_head(conn: sqlite3.Connection, kind: RecordKind, record_id: str) -> Record:
    record = find_head(conn, kind, record_id)
    if record is None:
        raise NotFound(f"no {kind.label} with id {record_id}")
    return record


def insert_version(
    conn: sqlite3.Connection,
    *,
    kind: RecordKind,
    record_id: str,
    version: int,
    parent_id: str | None,
    data_json: bytes,
    created_at: str | None,
    updated_by: str,
    device_id: str | None,
    deleted: bool = False,
    delete_reason: str | None = None,
) -> Record:
    """Write the next version and move the head. Call inside a write transaction."""
    now = iso(utcnow())
    cur = conn.execute(
        "INSERT INTO record_versions (kind, id, version, parent_id, data, deleted, delete_reason,"
        " created_at, updated_at, updated_by, device_id) VALUES (?,?,?,?,?,?,?,?,?,?,?)",
        (
            kind.value,
            record_id,
            version,
            parent_id,
            data_json.decode("utf-8"),
            int(deleted),
            delete_reason,
            created_at or now,
            now,
            updated_by,
            device_id,
        ),
    )
    conn.execute(
        "INSERT INTO record_heads (kind, id, seq, parent_id, deleted) VALUES (?,?,?,?,?)"
        " ON CONFLICT (kind, id) DO UPDATE SET seq = excluded.seq, parent_id = excluded.parent_id,"
        " deleted = excluded.deleted",
        (kind.value, record_id, cur.lastrowid, parent_id, int(deleted)),
    )
    row = conn.execute(f"SELECT {_COLUMNS} FROM record_versions v WHERE v.seq = ?", (cur.lastrowid,)).fetchone()
    return row_to_record(row)


def history(conn: sqlite3.Connection, kind: RecordKind, record_id: str) -> list[Record]:
    rows = conn.execute(
        f"SELECT {_COLUMNS} FROM record_versions v WHERE v.kind = ? AND v.id = ? ORDER BY v.version",
        (kind.value, record_id),
    ).fetchall()
    if not rows:
        raise NotFound(f"no {kind.label} with id {record_id}")
    return [row_to_record(r) for r in rows]


def list_heads(
    conn: sqlite3.Connection,
    kind: RecordKind,
    *,
    parent_id: str | None = None,
    include_deleted: bool = False,
    limit: int | None = 100,
    offset: int = 0,
) -> list[Record]:
    """Current versions, oldest first; limit None for all."""
    sql = f"SELECT {_COLUMNS} FROM record_heads h JOIN record_versions v ON v.seq = h.seq WHERE h.kind = ?"
    params: list = [kind.value]
    if parent_id is not None:
        sql += " AND h.parent_id = ?"
        params.append(parent_id)
    if not include_deleted:
        sql += " AND h.deleted = 0"
    sql += " ORDER BY v.created_at, v.id LIMIT ? OFFSET ?"
    params += [-1 if limit is None else limit, offset]
    return [row_to_record(r) for r in conn.execute(sql, params)]


def newest_heads(conn: sqlite3.Connection, kind: RecordKind, limit: int) -> list[Record]:
    """The `limit` live records of a kind most recently written, newest first."""
    sql = (
        f"SELECT {_COLUMNS} FROM record_heads h JOIN record_versions v ON v.seq = h.seq"
        " WHERE h.kind = ? AND h.deleted = 0 ORDER BY h.seq DESC LIMIT ?"
    )
    return [row_to_record(r) for r in conn.execute(sql, (kind.value, limit))]


def heads_of_children(
    conn: sqlite3.Connection, parent_id: str, kinds: Iterable[RecordKind]
) -> dict[RecordKind, Record]:
    wanted = [k.value for k in kinds]
    rows = conn.execute(
        f"SELECT {_COLUMNS} FROM record_heads h JOIN record_versions v ON v.seq = h.seq"
        f" WHERE h.id = ? AND h.kind IN ({','.join('?' * len(wanted))})",
        [parent_id, *wanted],
    )
    return {RecordKind(r["kind"]): row_to_record(r) for r in rows}


def changes_since(conn: sqlite3.Connection, cursor: int, limit: int, kinds: Iterable[RecordKind]) -> list[Record]:
    wanted = [k.value for k in kinds]
    rows = conn.execute(
        f"SELECT {_COLUMNS} FROM record_versions v WHERE v.seq > ? AND v.kind IN ({','.join('?' * len(wanted))})"
        " ORDER BY v.seq LIMIT ?",
        [cursor, *wanted, limit],
    )
    return [row_to_record(r) for r in rows]


class AppliedMutation(msgspec.Struct, frozen=True, kw_only=True):
    """A phone's mutation the gateway already applied, remembered so that a retried push gets the same answer."""

    fingerprint: str
    """What made it this mutation (everything but the phone's clock), to tell a reused mutation_id."""
    result: MutationResult
    """The answer the phone was given."""


_mutation_result = msgspec.json.Decoder(MutationResult)


def find_applied_mutation(conn: sqlite3.Connection, mutation_id: str) -> AppliedMutation | None:
    """The stored outcome of this mutation_id, or None when no mutation with it was applied yet."""
    row = conn.execute(
        "SELECT fingerprint, result FROM applied_mutations WHERE mutation_id = ?", (mutation_id,)
    ).fetchone()
    if row is None:
        return None
    return AppliedMutation(fingerprint=row["fingerprint"], result=_mutation_result.decode(row["result"]))


def remember_applied_mutation(conn: sqlite3.Connection, result: MutationResult, fingerprint: str, user_id: str) -> None:
    """Store an applied mutation's outcome, in the savepoint that applied it."""
    conn.execute(
        "INSERT INTO applied_mutations (mutation_id, fingerprint, result, applied_at, user_id) VALUES (?,?,?,?,?)",
        (result.mutation_id, fingerprint, msgspec.json.encode(result).decode(), iso(utcnow()), user_id),
    )
