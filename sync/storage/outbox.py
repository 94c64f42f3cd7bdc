"""The clinic's outbox table: one row per sealed bundle version, queued until the center's receipt."""

from __future__ import annotations

import sqlite3
from dataclasses import dataclass

from schemas.errors import NotFound
from schemas.transfer import OutboxBundle, OutboxEntry, OutboxState


@dataclass(frozen=True)
class OutboxCounts:
    """How many bundles the outbox holds in each state."""

    queued: int
    delivered: int


def latest(conn: sqlite3.Connection, center_id: str, encounter_id: str) -> OutboxBundle | None:
    """The newest version of the encounter queued for `center_id`; None when none was ever queued."""
    row = conn.execute(
        "SELECT * FROM outbox WHERE center_id = ? AND encounter_id = ? ORDER BY version DESC LIMIT 1",
        (center_id, encounter_id),
    ).fetchone()
    return _bundle(row) if row is not None else None


def insert_queued(
    conn: sqlite3.Connection,
    *,
    bundle_id: str,
    encounter_id: str,
    version: int,
    center_id: str,
    content_digest: str,
    envelope: bytes,
    chunks: int,
    size: int,
    created_at: str,
    created_by: str,
) -> None:
    """Add a sealed bundle in state queued; schemas.errors.DuplicateRow (from the write transaction) when that version was queued meanwhile."""
    conn.execute(
        "INSERT INTO outbox (bundle_id, encounter_id, version, center_id, content_digest, state,"
        " envelope, chunks, bytes, created_at, created_by) VALUES (?,?,?,?,?,?,?,?,?,?,?)",
        (
            bundle_id,
            encounter_id,
            version,
            center_id,
            content_digest,
            OutboxState.queued.value,
            envelope,
            chunks,
            size,
            created_at,
            created_by,
        ),
    )


def get(conn: sqlite3.Connection, bundle_id: str) -> OutboxBundle:
    row = conn.execute("SELECT * FROM outbox WHERE bundle_id = ?", (bundle_id,)).fetchone()
    if row is None:
        raise NotFound(f"no bundle {bundle_id} in the outbox")
    return _bundle(row)


def entries(conn: sqlite3.Connection, encounter_id: str | None, limit: int) -> list[OutboxEntry]:
    """The newest bundles first, of one encounter or of all."""
    sql, params = "SELECT * FROM outbox", []
    if encounter_id is not None:
        sql, params = sql + " WHERE encounter_id = ?", [encounter_id]
    rows = conn.execute(sql + " ORDER BY created_at DESC LIMIT ?", [*params, limit])
    return [_entry(r) for r in rows]


def pending(conn: sqlite3.Connection) -> list[OutboxBundle]:
    """Bundles still to deliver, oldest first (the center sees each clinic's versions in order)."""
    rows = conn.execute(
        "SELECT * FROM outbox WHERE state = ? ORDER BY created_at, version", (OutboxState.queued.value,)
    ).fetchall()
    return [_bundle(r) for r in rows]


def counts(conn: sqlite3.Connection) -> OutboxCounts:
    by_state = dict(conn.execute("SELECT state, COUNT(*) FROM outbox GROUP BY state").fetchall())
    return OutboxCounts(
        queued=by_state.get(OutboxState.queued.value, 0), delivered=by_state.get(OutboxState.delivered.value, 0)
    )


def record_progress(conn: sqlite3.Connection, bundle_id: str, sent_chunks: int) -> None:
    """Chunks acknowledged so far; never moves back."""
    conn.execute("UPDATE outbox SET sent_chunks = MAX(sent_chunks, ?) WHERE bundle_id = ?", (sent_chunks, bundle_id))


def record_failed_attempt(conn: sqlite3.Connection, bundle_id: str, error: str) -> None:
    conn.execute("UPDATE outbox SET attempts = attempts + 1, last_error = ? WHERE bundle_id = ?", (error, bundle_id))


def mark_delivered(conn: sqlite3.Connection, bundle_id: str, delivered_at: str, receipt: bytes) -> None:
    """Delivered with the center's signed receipt (msgpack of its envelope): every chunk counts as sent."""
    conn.execute(
        "UPDATE outbox SET state = ?, delivered_at = ?, receipt = ?, sent_chunks = chunks,"
        " last_error = NULL WHERE bundle_id = ?",
        (OutboxState.delivered.value, delivered_at, receipt, bundle_id),
    )


def _bundle(row: sqlite3.Row) -> OutboxBundle:
    return OutboxBundle(entry=_entry(row), content_digest=row["content_digest"], envelope=bytes(row["envelope"]))


def _entry(row: sqlite3.Row) -> OutboxEntry:
    return OutboxEntry(
        bundle_id=row["bundle_id"],
        encounter_id=row["encounter_id"],
        version=row["version"],
        center_id=row["center_id"],
        state=OutboxState(row["state"]),
        chunks=row["chunks"],
        sent_chunks=row["sent_chunks"],
        bytes=row["bytes"],
        created_at=row["created_at"],
        created_by=row["created_by"],
        attempts=row["attempts"],
        last_error=row["last_error"],
        delivered_at=row["delivered_at"],
    )
