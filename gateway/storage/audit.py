"""The append-only, hash-chained audit log.

Each entry's hash covers its own fields and the previous entry's hash, so changing,
inserting or removing a past entry breaks every hash after it. Removing entries from
the end is only detectable against a head hash kept elsewhere (see docs/security.md).
"""

from __future__ import annotations

import hashlib
import json
import sqlite3
from collections.abc import Iterator

from schemas.audit import AuditEntry, AuditVerification
from schemas.base import utcnow

GENESIS_HASH = "0" * 64
_HASHED_FIELDS = (
    "seq", "at", "user_id", "device_id", "action", "kind", "record_id",
    "before_version", "after_version", "detail", "prev_hash",
)  # fmt: skip


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
) -> AuditEntry:
    """Append one entry. Call inside the write transaction of the change it records."""
    last = conn.execute("SELECT seq, hash FROM audit_log ORDER BY seq DESC LIMIT 1").fetchone()
    fields = {
        "seq": (last["seq"] + 1) if last else 1,
        "at": utcnow().isoformat(timespec="microseconds"),
        "user_id": user_id,
        "device_id": device_id,
        "action": action,
        "kind": kind,
        "record_id": record_id,
        "before_version": before_version,
        "after_version": after_version,
        "detail": detail,
        "prev_hash": last["hash"] if last else GENESIS_HASH,
    }
    fields["hash"] = entry_hash(fields)
    conn.execute(
        f"INSERT INTO audit_log ({', '.join(fields)}) VALUES ({', '.join('?' * len(fields))})",
        list(fields.values()),
    )
    return AuditEntry(**fields)


def entries(conn: sqlite3.Connection, after_seq: int = 0, limit: int | None = None) -> Iterator[AuditEntry]:
    sql = "SELECT * FROM audit_log WHERE seq > ? ORDER BY seq"
    params: list = [after_seq]
    if limit is not None:
        sql += " LIMIT ?"
        params.append(limit)
    for row in conn.execute(sql, params):
        yield AuditEntry(**dict(row))


def verify(conn: sqlite3.Connection) -> AuditVerification:
    """Walk the chain from the start; name the first entry that does not fit."""
    expected_prev = GENESIS_HASH
    count = 0
    for entry in entries(conn):
        count += 1
        fields = {name: getattr(entry, name) for name in _HASHED_FIELDS}
        if entry.seq != count:
            return _broken(count, entry.seq, f"entry {count} is missing (next entry found is {entry.seq})")
        if entry.prev_hash != expected_prev:
            return _broken(
                count, entry.seq, f"entry {entry.seq} does not follow entry {entry.seq - 1}: previous-hash mismatch"
            )
        if entry_hash(fields) != entry.hash:
            return _broken(count, entry.seq, f"entry {entry.seq} was altered: its content does not match its hash")
        expected_prev = entry.hash
    return AuditVerification(ok=True, entries=count, first_broken_seq=None, reason=f"all {count} entries intact")


def _broken(count: int, seq: int, reason: str) -> AuditVerification:
    return AuditVerification(ok=False, entries=count, first_broken_seq=min(seq, count), reason=reason)
