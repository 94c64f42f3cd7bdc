"""Rows of consultants' notes on their way back to clinics (`notes`, `mail_cursors`): each note as written and as
sealed for its clinic, and how far each clinic has confirmed it stored them."""

from __future__ import annotations

import sqlite3
import time

import msgspec

from schemas.central import NoteStatus
from schemas.transfer import ConsultationNote, SignedEnvelope

_envelope = msgspec.msgpack.Decoder(SignedEnvelope)


def encounter_notes(conn: sqlite3.Connection, site_id: str, encounter_id: str) -> list[NoteStatus]:
    """Every note written on the site's encounter, oldest first, with when the clinic confirmed it."""
    rows = conn.execute(
        "SELECT note, delivered_at FROM notes WHERE site_id = ? AND encounter_id = ? ORDER BY seq",
        (site_id, encounter_id),
    ).fetchall()
    return [
        NoteStatus(note=msgspec.json.decode(r["note"], type=ConsultationNote), delivered_at=r["delivered_at"])
        for r in rows
    ]


def _next_seq(conn: sqlite3.Connection) -> int:
    # Numbered by the clock (microseconds), not by the table's counter: a clinic asks for the notes after the
    # highest number it has read, and a database restored from a backup would count again from the backup's last
    # number, below what clinics read before the loss, so they would never ask for new advice. The clock has moved
    # on past every number given out before. Callers hold the write lock, so numbers stay unique and rising.
    last = conn.execute("SELECT MAX(seq) FROM notes").fetchone()[0] or 0
    return max(last + 1, time.time_ns() // 1000)


def insert_note(conn: sqlite3.Connection, site_id: str, note: ConsultationNote) -> int:
    """Store a note for the site, not sealed yet, marking the versions it advises on; its sequence number in the
    site's mail."""
    row = conn.execute(
        "INSERT INTO notes (seq, note_id, site_id, encounter_id, bundle_id, consultant_user_id, note,"
        " written_at) VALUES (?,?,?,?,?,?,?,?) RETURNING seq",
        (
            _next_seq(conn),
            note.note_id,
            site_id,
            note.encounter_id,
            note.bundle_id,
            note.consultant_user_id,
            msgspec.json.encode(note).decode(),
            note.written_at,
        ),
    ).fetchone()
    conn.execute(
        "UPDATE bundles SET advised = 1 WHERE site_id = ? AND encounter_id = ? AND stored_at <= ? AND advised = 0",
        (site_id, note.encounter_id, note.written_at),
    )
    return row["seq"]


def attach_sealed(conn: sqlite3.Connection, seq: int, message: SignedEnvelope) -> None:
    """The note `seq` as sealed and signed for its clinic: what the clinic's mail request fetches."""
    conn.execute("UPDATE notes SET message = ? WHERE seq = ?", (msgspec.msgpack.encode(message), seq))


def mark_delivered(conn: sqlite3.Connection, site_id: str, up_to_seq: int, at: str) -> None:
    """The site confirmed it stored its notes up to `up_to_seq`."""
    conn.execute(
        "UPDATE notes SET delivered_at = ? WHERE site_id = ? AND seq <= ? AND delivered_at IS NULL",
        (at, site_id, up_to_seq),
    )


def record_poll(conn: sqlite3.Connection, site_id: str, acked_seq: int, at: str) -> None:
    """The site polled its mail at `at`, having stored its notes up to `acked_seq` (a cursor never goes back)."""
    conn.execute(
        "INSERT INTO mail_cursors (site_id, acked_seq, last_poll_at) VALUES (?,?,?) ON CONFLICT"
        " (site_id) DO UPDATE SET acked_seq = CASE WHEN excluded.acked_seq > mail_cursors.acked_seq"
        " THEN excluded.acked_seq ELSE mail_cursors.acked_seq END,"
        " last_poll_at = excluded.last_poll_at",
        (site_id, acked_seq, at),
    )


def sealed_after(conn: sqlite3.Connection, site_id: str, after_seq: int, limit: int) -> list[SignedEnvelope]:
    """Up to `limit` of the site's sealed notes after `after_seq`, in order."""
    rows = conn.execute(
        "SELECT message FROM notes WHERE site_id = ? AND seq > ? AND message IS NOT NULL ORDER BY seq LIMIT ?",
        (site_id, after_seq, limit),
    ).fetchall()
    return [_envelope.decode(r["message"]) for r in rows]
