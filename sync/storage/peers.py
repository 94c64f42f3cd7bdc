"""The peers table: the sites a site trusts, with their public keys as enrolled and when they were revoked."""

from __future__ import annotations

import sqlite3

import msgspec

from schemas.errors import NotFound
from schemas.transfer import Peer, SiteIdentity, SiteRole

PEERS_DDL = """
    CREATE TABLE peers (
        site_id TEXT PRIMARY KEY,
        role TEXT NOT NULL,
        identity TEXT NOT NULL,
        fingerprint TEXT NOT NULL,
        enrolled_at TEXT NOT NULL,
        enrolled_by TEXT NOT NULL,
        revoked_at TEXT,
        revoke_reason TEXT
    )"""


def find(conn: sqlite3.Connection, site_id: str) -> Peer | None:
    """The enrolled site, revoked or not; None when it was never enrolled."""
    row = conn.execute("SELECT * FROM peers WHERE site_id = ?", (site_id,)).fetchone()
    return _peer(row) if row is not None else None


def get(conn: sqlite3.Connection, site_id: str) -> Peer:
    peer = find(conn, site_id)
    if peer is None:
        raise NotFound(f"no enrolled site is called {site_id}")
    return peer


def list_all(conn: sqlite3.Connection) -> list[Peer]:
    """Every enrolled site, revoked ones too, by site id."""
    return [_peer(r) for r in conn.execute("SELECT * FROM peers ORDER BY site_id")]


def unrevoked_ids(conn: sqlite3.Connection, role: SiteRole) -> list[str]:
    rows = conn.execute("SELECT site_id FROM peers WHERE role = ? AND revoked_at IS NULL", (role.value,)).fetchall()
    return [r["site_id"] for r in rows]


def upsert(conn: sqlite3.Connection, identity: SiteIdentity, *, fingerprint: str, at: str, by: str) -> None:
    """Enrol the site, or enrol it again with these keys: a revocation is lifted."""
    conn.execute(
        "INSERT INTO peers (site_id, role, identity, fingerprint, enrolled_at, enrolled_by) VALUES (?,?,?,?,?,?)"
        " ON CONFLICT (site_id) DO UPDATE SET role = excluded.role, identity = excluded.identity,"
        " fingerprint = excluded.fingerprint, enrolled_at = excluded.enrolled_at,"
        " enrolled_by = excluded.enrolled_by, revoked_at = NULL, revoke_reason = NULL",
        (identity.site_id, identity.role.value, msgspec.json.encode(identity).decode(), fingerprint, at, by),
    )


def set_revoked(conn: sqlite3.Connection, site_id: str, *, at: str, reason: str) -> None:
    conn.execute("UPDATE peers SET revoked_at = ?, revoke_reason = ? WHERE site_id = ?", (at, reason, site_id))


def _peer(row: sqlite3.Row) -> Peer:
    return Peer(
        identity=msgspec.json.decode(row["identity"], type=SiteIdentity),
        fingerprint=row["fingerprint"],
        enrolled_at=row["enrolled_at"],
        enrolled_by=row["enrolled_by"],
        revoked_at=row["revoked_at"],
        revoke_reason=row["revoke_reason"],
    )
