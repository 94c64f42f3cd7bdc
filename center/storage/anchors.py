"""Rows of the audit-chain heads the center signed for clinics (`audit_anchors`); voided ones stay, marked."""

from __future__ import annotations

import sqlite3

from schemas.audit import AuditHead
from schemas.central import StoredAnchor


def latest_anchor(conn: sqlite3.Connection, site_id: str) -> StoredAnchor | None:
    """The site's newest anchor not voided, or None when it has none."""
    row = conn.execute(
        "SELECT seq, hash, anchored_at FROM audit_anchors WHERE site_id = ? AND voided_at IS NULL"
        " ORDER BY seq DESC, id DESC LIMIT 1",
        (site_id,),
    ).fetchone()
    if row is None:
        return None
    return StoredAnchor(head=AuditHead(seq=row["seq"], hash=row["hash"]), anchored_at=row["anchored_at"])


def insert_anchor(conn: sqlite3.Connection, site_id: str, head: AuditHead, anchored_at: str) -> None:
    conn.execute(
        "INSERT INTO audit_anchors (site_id, seq, hash, anchored_at) VALUES (?,?,?,?)",
        (site_id, head.seq, head.hash, anchored_at),
    )


def void_anchors(conn: sqlite3.Connection, site_id: str, at: str) -> int:
    """Void the site's anchors not voided yet; how many were."""
    return conn.execute(
        "UPDATE audit_anchors SET voided_at = ? WHERE site_id = ? AND voided_at IS NULL", (at, site_id)
    ).rowcount
