"""The `pacs_sends` table: each send of an encounter to the hospital's PACS and how it ended
(gateway/documents/dicom.py writes it, with its audit entries, in the same transactions)."""

from __future__ import annotations

import sqlite3

from schemas.dicom import PacsSend, PacsSendState

COLUMNS = (
    "id, subject_id, endpoint, state, study_uid, requested_by, started_at, finished_at, instances, already_there, error"
)


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
        f"SELECT {COLUMNS} FROM pacs_sends WHERE subject_id = ? ORDER BY started_at DESC, rowid DESC", (subject_id,)
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
