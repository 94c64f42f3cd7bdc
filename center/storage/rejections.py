"""Rows of what clinics sent that the center refused (`rejections`), the newest KEEP_REJECTIONS kept."""

from __future__ import annotations

import sqlite3

from schemas.central import RejectionItem

KEEP_REJECTIONS = 10_000


def record_rejection(
    conn: sqlite3.Connection, *, at: str, site_id: str | None, code: str, reason: str, key: str
) -> None:
    """Keep a refusal, forgetting the oldest beyond KEEP_REJECTIONS."""
    conn.execute(
        "INSERT INTO rejections (at, site_id, code, reason, key) VALUES (?,?,?,?,?)", (at, site_id, code, reason, key)
    )
    conn.execute("DELETE FROM rejections WHERE id <= (SELECT MAX(id) FROM rejections) - ?", (KEEP_REJECTIONS,))


def latest_rejections(conn: sqlite3.Connection, limit: int) -> list[RejectionItem]:
    """The newest `limit` refusals, newest first."""
    rows = conn.execute("SELECT * FROM rejections ORDER BY id DESC LIMIT ?", (limit,))
    return [
        RejectionItem(at=r["at"], site_id=r["site_id"], code=r["code"], reason=r["reason"], key=r["key"]) for r in rows
    ]
