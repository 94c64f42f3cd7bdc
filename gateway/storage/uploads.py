"""The uploads table: resumable (tus) uploads in progress and how each ended.

Knows SQL, not capture rules: the upload service decides what to store and writes the audit entries, in the same
transaction, through the connection it passes in.
"""

from __future__ import annotations

import json
import sqlite3

from schemas.capture import StoredUpload, UploadPhase
from schemas.errors import NotFound

# uploads -----------------------------------------------------------------------------------


def _upload(row: sqlite3.Row) -> StoredUpload:
    return StoredUpload(
        id=row["id"],
        encounter_id=row["encounter_id"],
        length=row["length"],
        metadata=json.loads(row["metadata"]),
        filename=row["filename"],
        state=UploadPhase(row["state"]),
        created_by=row["created_by"],
        device_id=row["device_id"],
        created_at=row["created_at"],
        expires_at=row["expires_at"],
        asset_id=row["asset_id"],
        error=row["error"],
    )


def get_upload(conn: sqlite3.Connection, upload_id: str) -> StoredUpload:
    """The upload with this id; NotFound if there is none."""
    row = conn.execute("SELECT * FROM uploads WHERE id = ?", (upload_id,)).fetchone()
    if row is None:
        raise NotFound(f"no upload {upload_id}")
    return _upload(row)


def open_uploads(conn: sqlite3.Connection) -> list[StoredUpload]:
    """The uploads still receiving bytes (or all received and not yet recorded)."""
    return [_upload(r) for r in conn.execute("SELECT * FROM uploads WHERE state = 'open'").fetchall()]


def insert_upload(conn: sqlite3.Connection, upload: StoredUpload) -> None:
    """Write a new upload row, inside the caller's transaction."""
    conn.execute(
        "INSERT INTO uploads (id, encounter_id, length, metadata, filename, state, created_by, device_id,"
        " created_at, expires_at) VALUES (?,?,?,?,?,?,?,?,?,?)",
        (
            upload.id,
            upload.encounter_id,
            upload.length,
            json.dumps(upload.metadata),
            upload.filename,
            upload.state.value,
            upload.created_by,
            upload.device_id,
            upload.created_at,
            upload.expires_at,
        ),
    )


def mark_upload_complete(conn: sqlite3.Connection, upload_id: str, asset_id: str) -> None:
    """An open upload becomes complete, naming the asset it was stored as."""
    conn.execute(
        "UPDATE uploads SET state = 'complete', asset_id = ?, error = NULL WHERE id = ? AND state = 'open'",
        (asset_id, upload_id),
    )


def end_upload(conn: sqlite3.Connection, upload_id: str, phase: UploadPhase, error: str | None) -> bool:
    """Move an open upload to its end state; False if it had already ended another way."""
    cur = conn.execute(
        "UPDATE uploads SET state = ?, error = ? WHERE id = ? AND state = 'open'",
        (phase.value, error, upload_id),
    )
    return cur.rowcount == 1
