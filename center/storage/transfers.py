"""Rows of transfers in progress (`incoming`): a clinic's signed announcement of a bundle, kept until its commit
stores the bundle or the transfer is dropped."""

from __future__ import annotations

import sqlite3

from schemas.central import Announcement, RefusedBundle


def _announcement(row: sqlite3.Row) -> Announcement:
    return Announcement(
        site_id=row["site_id"],
        bundle_id=row["bundle_id"],
        envelope=row["envelope"],
        manifest_sha256=row["manifest_sha256"],
        encounter_id=row["encounter_id"],
        version=row["version"],
        chunks=row["chunks"],
        announced_at=row["announced_at"],
    )


def find_announcement(conn: sqlite3.Connection, site_id: str, bundle_id: str) -> Announcement | None:
    """The site's announcement of this bundle, or None when none is waiting for its commit."""
    row = conn.execute("SELECT * FROM incoming WHERE site_id = ? AND bundle_id = ?", (site_id, bundle_id)).fetchone()
    return _announcement(row) if row else None


def insert_announcement(conn: sqlite3.Connection, announcement: Announcement) -> None:
    conn.execute(
        "INSERT INTO incoming (site_id, bundle_id, envelope, manifest_sha256, encounter_id,"
        " version, chunks, announced_at) VALUES (?,?,?,?,?,?,?,?)",
        (
            announcement.site_id,
            announcement.bundle_id,
            announcement.envelope,
            announcement.manifest_sha256,
            announcement.encounter_id,
            announcement.version,
            announcement.chunks,
            announcement.announced_at,
        ),
    )


def delete_announcement(conn: sqlite3.Connection, site_id: str, bundle_id: str) -> None:
    conn.execute("DELETE FROM incoming WHERE site_id = ? AND bundle_id = ?", (site_id, bundle_id))


def announced_before(conn: sqlite3.Connection, cutoff: str) -> list[Announcement]:
    """Transfers announced before `cutoff` (a stored timestamp) and not committed since."""
    return [_announcement(r) for r in conn.execute("SELECT * FROM incoming WHERE announced_at < ?", (cutoff,))]


def refuse(conn: sqlite3.Connection, refusal: RefusedBundle) -> None:
    """The transfer ends refused: its announcement goes, the reason stays (the first one, if told twice)."""
    delete_announcement(conn, refusal.site_id, refusal.bundle_id)
    conn.execute(
        "INSERT INTO refused_bundles (site_id, bundle_id, code, reason, refused_at) VALUES (?,?,?,?,?)"
        " ON CONFLICT (site_id, bundle_id) DO NOTHING",
        (refusal.site_id, refusal.bundle_id, refusal.code, refusal.reason, refusal.refused_at),
    )


def find_refusal(conn: sqlite3.Connection, site_id: str, bundle_id: str) -> RefusedBundle | None:
    """Why the bundle was refused, or None when it was not."""
    row = conn.execute(
        "SELECT * FROM refused_bundles WHERE site_id = ? AND bundle_id = ?", (site_id, bundle_id)
    ).fetchone()
    if row is None:
        return None
    return RefusedBundle(
        site_id=row["site_id"],
        bundle_id=row["bundle_id"],
        code=row["code"],
        reason=row["reason"],
        refused_at=row["refused_at"],
    )


def forget_refusals_before(conn: sqlite3.Connection, cutoff: str) -> int:
    """Forget bundles refused before `cutoff`; how many."""
    return conn.execute("DELETE FROM refused_bundles WHERE refused_at < ?", (cutoff,)).rowcount
