"""The `pacs_sends` table, kept by both servers: each send of an encounter (the clinic) or a received case (the
burn center) to the hospital's PACS and how it ended; written with its audit entries in the same transactions
(gateway/documents/dicom.py, center/pacs.py). Plain SQL that SQLite and PostgreSQL both run."""

from __future__ import annotations

import datetime as dt
import sqlite3

import msgspec
from sqlite_utils import Database

from schemas.dicom import PacsSend, PacsSendState

COLUMNS = (
    "id, subject_id, endpoint, state, study_uid, requested_by, started_at, finished_at, instances, already_there, error"
)


def create_table(db: Database) -> None:
    """The table (the gateway's migration m013, the center's c007)."""
    db.execute(
        """
        CREATE TABLE pacs_sends (
            id TEXT PRIMARY KEY,
            subject_id TEXT NOT NULL,
            endpoint TEXT NOT NULL,
            state TEXT NOT NULL,
            study_uid TEXT NOT NULL,
            requested_by TEXT NOT NULL,
            started_at TEXT NOT NULL,
            finished_at TEXT,
            instances INTEGER NOT NULL DEFAULT 0,
            already_there INTEGER NOT NULL DEFAULT 0,
            error TEXT NOT NULL DEFAULT ''
        )
        """
    )
    db.execute("CREATE INDEX pacs_sends_subject ON pacs_sends (subject_id, started_at)")


def begin(conn: sqlite3.Connection, send: PacsSend) -> None:
    conn.execute(
        f"INSERT INTO pacs_sends ({COLUMNS}) VALUES (?,?,?,?,?,?,?,?,?,?,?)",
        (
            send.id,
            send.subject_id,
            send.endpoint,
            send.state.value,
            send.study_uid,
            send.requested_by,
            send.started_at,
            send.finished_at,
            send.instances,
            send.already_there,
            send.error,
        ),
    )


def finish(
    conn: sqlite3.Connection,
    send_id: str,
    state: PacsSendState,
    finished_at: str,
    *,
    instances: int = 0,
    already_there: int = 0,
    error: str = "",
) -> None:
    conn.execute(
        "UPDATE pacs_sends SET state = ?, finished_at = ?, instances = ?, already_there = ?, error = ? WHERE id = ?",
        (state.value, finished_at, instances, already_there, error, send_id),
    )


def of_subject(conn: sqlite3.Connection, subject_id: str) -> list[PacsSend]:
    """The subject's sends, newest first."""
    rows = conn.execute(
        f"SELECT {COLUMNS} FROM pacs_sends WHERE subject_id = ? ORDER BY started_at DESC, id DESC", (subject_id,)
    ).fetchall()
    return [
        PacsSend(
            id=r["id"],
            subject_id=r["subject_id"],
            endpoint=r["endpoint"],
            state=PacsSendState(r["state"]),
            study_uid=r["study_uid"],
            requested_by=r["requested_by"],
            started_at=r["started_at"],
            finished_at=r["finished_at"],
            instances=r["instances"],
            already_there=r["already_there"],
            error=r["error"],
        )
        for r in rows
    ]


def settled(send: PacsSend, stale_s: float) -> PacsSend:
    """A send still "sending" `stale_s` after it started was cut short (its server stopped): read as failed."""
    if send.state is not PacsSendState.sending:
        return send
    if (dt.datetime.now(dt.UTC) - dt.datetime.fromisoformat(send.started_at)).total_seconds() < stale_s:
        return send
    cut = "the send was cut short (the server stopped): send again"
    return msgspec.structs.replace(send, state=PacsSendState.failed, error=cut)
