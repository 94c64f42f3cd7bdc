"""The append-only, hash-chained audit log.

Each entry's hash covers its own fields and the previous entry's hash, so changing,
inserting or removing a past entry breaks the chain. Entries that record a record
version also carry that version's content hash, so editing stored record data is
detected too. Every record head must point at the newest version the chain recorded, so
a head moved back to an older version (a rolled-back record) is detected. Removing entries
from the end is detectable against a head kept elsewhere: the burn center's signed anchor
(see docs/security.md).
"""

from __future__ import annotations

import hashlib
import json
import sqlite3
from collections.abc import Iterator

from base.storage.records import insert_version, version_content_hash
from schemas.audit import AuditAnchor, AuditEntry, AuditHead, AuditVerification
from schemas.base import iso, utcnow
from schemas.records import RecordKind

GENESIS_HASH = "0" * 64
SERVER_USER = "gateway"
"""`updated_by` of the records the gateway writes itself (analyses, consultations received)."""
_HASHED_FIELDS = (
    "seq",
    "at",
    "user_id",
    "device_id",
    "action",
    "kind",
    "record_id",
    "before_version",
    "after_version",
    "detail",
    "content_hash",
    "prev_hash",
)


def entry_hash(fields: dict) -> str:
    canonical = json.dumps([fields[name] for name in _HASHED_FIELDS], separators=(",", ":"), ensure_ascii=False)
    return hashlib.sha256(canonical.encode("utf-8")).hexdigest()


def append(
    conn: sqlite3.Connection,
    *,
    action: str,
    user_id: str | None,
    device_id: str | None,
    kind: str | None = None,
    record_id: str | None = None,
    before_version: int | None = None,
    after_version: int | None = None,
    detail: str = "",
    content_hash: str | None = None,
) -> AuditEntry:
    """Append one entry. Call inside the write transaction of the change it records."""
    last = conn.execute("SELECT seq, hash FROM audit_log ORDER BY seq DESC LIMIT 1").fetchone()
    fields = {
        "seq": (last["seq"] + 1) if last else 1,
        "at": iso(utcnow()),
        "user_id": user_id,
        "device_id": device_id,
        "action": action,
        "kind": kind,
        "record_id": record_id,
        "before_version": before_version,
        "after_version": after_version,
        "detail": detail,
        "content_hash": content_hash,
        "prev_hash": last["hash"] if last else GENESIS_HASH,
    }
    fields["hash"] = entry_hash(fields)
    conn.execute(
        f"INSERT INTO audit_log ({', '.join(fields)}) VALUES ({', '.join('?' * len(fields))})",
        list(fields.values()),
    )
    return AuditEntry(**fields)


def insert_server_record(
    conn: sqlite3.Connection,
    *,
    kind: RecordKind,
    record_id: str,
    parent_id: str,
    data: bytes,
    action: str,
    detail: str = "",
) -> None:
    """The first version of a record the gateway writes itself, with its audit entry; inside a write transaction."""
    insert_version(
        conn,
        kind=kind,
        record_id=record_id,
        version=1,
        parent_id=parent_id,
        data_json=data,
        created_at=None,
        updated_by=SERVER_USER,
        device_id=None,
    )
    append(
        conn,
        action=action,
        user_id=None,
        device_id=None,
        kind=kind.value,
        record_id=record_id,
        after_version=1,
        detail=detail,
        content_hash=version_content_hash(data.decode(), False, None),
    )


def entries(conn: sqlite3.Connection, after_seq: int = 0, limit: int | None = None) -> Iterator[AuditEntry]:
    sql = "SELECT * FROM audit_log WHERE seq > ? ORDER BY seq"
    params: list = [after_seq]
    if limit is not None:
        sql += " LIMIT ?"
        params.append(limit)
    for row in conn.execute(sql, params):
        yield AuditEntry(**dict(row))


def head(conn: sqlite3.Connection) -> AuditHead | None:
    """The newest entry's sequence number and hash; None for an empty chain (a database never written)."""
    row = conn.execute("SELECT seq, hash FROM audit_log ORDER BY seq DESC LIMIT 1").fetchone()
    return AuditHead(seq=row["seq"], hash=row["hash"]) if row else None


def hash_at(conn: sqlite3.Connection, seq: int) -> str | None:
    row = conn.execute("SELECT hash FROM audit_log WHERE seq = ?", (seq,)).fetchone()
    return row["hash"] if row else None


def verify(
    conn: sqlite3.Connection, anchor: AuditAnchor | None = None, *, served_records: bool = True
) -> AuditVerification:
    """Walk the chain from the start and name the first entry that does not fit; then check that the chain still
    reaches `anchor` unchanged, and (with `served_records`, at a gateway: the center serves no records of its own)
    that every record head is the newest version the chain recorded.

    When entry N was rewritten with a recomputed hash, N itself looks intact and the
    break shows at N + 1: the chain can say where it stops holding, not who forged what.
    """
    expected_prev = GENESIS_HASH
    count = 0
    newest: dict[tuple[str, str], tuple[int, int]] = {}
    """(kind, id) -> (version, seq of the entry that recorded it)."""
    for entry in entries(conn):
        count += 1
        fields = {name: getattr(entry, name) for name in _HASHED_FIELDS}
        if entry.seq != count:
            return _broken(count, f"entry {count} is missing (next entry found is {entry.seq})")
        if entry.prev_hash != expected_prev:
            return _broken(
                entry.seq, f"entry {entry.seq} does not follow entry {entry.seq - 1}: previous-hash mismatch"
            )
        if entry_hash(fields) != entry.hash:
            return _broken(entry.seq, f"entry {entry.seq} was altered: its content does not match its hash")
        problem = _record_content_problem(conn, entry)
        if problem:
            return _broken(entry.seq, problem)
        if entry.content_hash is not None:
            newest[(entry.kind, entry.record_id)] = (entry.after_version, entry.seq)
        expected_prev = entry.hash
    if anchor is not None:  # first: a chain cut back also leaves heads unrecorded, but this says what happened
        problem = _anchor_problem(conn, anchor, count)
        if problem:
            return AuditVerification(ok=False, entries=count, first_broken_seq=anchor.head.seq, reason=problem)
    problem = _head_problem(conn, newest) if served_records else None
    if problem:
        seq, reason = problem
        return AuditVerification(ok=False, entries=count, first_broken_seq=seq or None, reason=reason)
    served = "; every record served is its newest audited version" if served_records else ""
    anchored = f"; reaches the burn center's anchor (entry {anchor.head.seq}, {anchor.anchored_at})" if anchor else ""
    return AuditVerification(
        ok=True, entries=count, first_broken_seq=None, reason=f"all {count} entries intact{served}{anchored}"
    )


def _head_problem(conn: sqlite3.Connection, newest: dict[tuple[str, str], tuple[int, int]]) -> tuple[int, str] | None:
    """What the API serves (record_heads) against what the chain recorded last, record by record."""
    unseen = dict(newest)
    rows = conn.execute(
        "SELECT h.kind, h.id, h.deleted AS head_deleted, v.kind AS v_kind, v.id AS v_id, v.version, v.deleted"
        " FROM record_heads h LEFT JOIN record_versions v ON v.seq = h.seq ORDER BY h.kind, h.id"
    )
    for row in rows:
        key = (row["kind"], row["id"])
        what = f"{row['kind']} {row['id']}"
        recorded = unseen.pop(key, None)
        if recorded is None:
            return 0, f"{what} is served but no audit entry records it: it was written outside the gateway"
        version, seq = recorded
        if (row["v_kind"], row["v_id"]) != key:
            return seq, f"{what} is served from a version row that is missing or belongs to another record"
        if row["version"] != version:
            change = "rolled back to" if row["version"] < version else "moved to unaudited"
            return seq, (
                f"{what} is served at version {row['version']}, but entry {seq} recorded version {version} "
                f"as its newest: the record was {change} version {row['version']}"
            )
        if bool(row["head_deleted"]) != bool(row["deleted"]):
            return seq, f"{what}: its withdrawn flag does not match its newest version"
    if unseen:
        (kind, record_id), (version, seq) = next(iter(unseen.items()))
        return seq, f"{kind} {record_id} version {version}, recorded by entry {seq}, is no longer served: head removed"
    return None


def _anchor_problem(conn: sqlite3.Connection, anchor: AuditAnchor, count: int) -> str | None:
    seq, when = anchor.head.seq, anchor.anchored_at
    if count < seq:
        return (
            f"the chain ends at entry {count}, but burn center {anchor.center_id} anchored entry {seq} on {when}: "
            f"entries {count + 1} to {seq} were removed, or the database was replaced by an older copy"
        )
    if hash_at(conn, seq) != anchor.head.hash:
        return (
            f"entry {seq} is not the one burn center {anchor.center_id} anchored on {when}: the chain up to it "
            "was rewritten"
        )
    return None


def _record_content_problem(conn: sqlite3.Connection, entry: AuditEntry) -> str | None:
    if entry.content_hash is None:
        return None
    row = conn.execute(
        "SELECT data, deleted, delete_reason FROM record_versions WHERE kind = ? AND id = ? AND version = ?",
        (entry.kind, entry.record_id, entry.after_version),
    ).fetchone()
    what = f"{entry.kind} {entry.record_id} version {entry.after_version}"
    if row is None:
        return f"{what}, recorded by entry {entry.seq}, is missing from the record store"
    if version_content_hash(row["data"], bool(row["deleted"]), row["delete_reason"]) != entry.content_hash:
        return f"{what} was altered after entry {entry.seq} recorded it"
    return None


def _broken(seq: int, reason: str) -> AuditVerification:
    return AuditVerification(ok=False, entries=seq, first_broken_seq=seq, reason=reason)
