"""The `advice_read` table: which consultant advice (consultation record versions) the clinic has read. The
advice itself is a record (kind consultation, its parent the encounter) written by the sync mailbox."""

from __future__ import annotations

import sqlite3
from dataclasses import dataclass


@dataclass(frozen=True)
class UnreadAdvice:
    consultation_id: str
    version: int
    encounter_id: str
    patient_id: str


def unread(conn: sqlite3.Connection) -> list[UnreadAdvice]:
    """Live advice not read at its current version, oldest first, with its encounter's patient."""
    rows = conn.execute(
        "SELECT c.id, v.version, c.parent_id AS encounter_id, e.parent_id AS patient_id"
        " FROM record_heads c JOIN record_versions v ON v.seq = c.seq"
        " JOIN record_heads e ON e.kind = 'encounter' AND e.id = c.parent_id"
        " WHERE c.kind = 'consultation' AND c.deleted = 0"
        " AND NOT EXISTS (SELECT 1 FROM advice_read r WHERE r.consultation_id = c.id AND r.version = v.version)"
        " ORDER BY c.seq"
    )
    return [UnreadAdvice(r["id"], r["version"], r["encounter_id"], r["patient_id"]) for r in rows]


def mark_read(conn: sqlite3.Connection, advice: list[UnreadAdvice], by: str, at: str) -> None:
    """Record these as read, inside the caller's transaction (already read: left as it was)."""
    conn.executemany(
        "INSERT OR IGNORE INTO advice_read (consultation_id, version, read_by, read_at) VALUES (?, ?, ?, ?)",
        [(a.consultation_id, a.version, by, at) for a in advice],
    )
