"""The sites a site trusts: enrolled with their public keys, revocable, every change audited."""

from __future__ import annotations

import sqlite3

import msgspec

from base.storage import audit
from base.storage.database import Database
from schemas.base import iso, utcnow
from schemas.errors import Conflict, NotFound, TransferRejected
from schemas.transfer import Peer, SiteIdentity, SiteRole
from sync.keys import check_identity, fingerprint

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


def enrol(db: Database, identity: SiteIdentity, *, by: str, replace: bool = False) -> Peer:
    """Trust `identity`; an enrolled site's keys are only replaced with `replace` (after the site made new keys)."""
    check_identity(identity)
    now = iso(utcnow())
    with db.write() as conn:
        row = conn.execute("SELECT identity FROM peers WHERE site_id = ?", (identity.site_id,)).fetchone()
        if row is not None and not replace and msgspec.json.decode(row["identity"], type=SiteIdentity) != identity:
            raise Conflict(
                f"{identity.site_id} is already enrolled with other keys: check the fingerprint with the "
                "site, then enrol again with --replace"
            )
        conn.execute(
            "INSERT INTO peers (site_id, role, identity, fingerprint, enrolled_at, enrolled_by) VALUES (?,?,?,?,?,?)"
            " ON CONFLICT (site_id) DO UPDATE SET role = excluded.role, identity = excluded.identity,"
            " fingerprint = excluded.fingerprint, enrolled_at = excluded.enrolled_at,"
            " enrolled_by = excluded.enrolled_by, revoked_at = NULL, revoke_reason = NULL",
            (
                identity.site_id,
                identity.role.value,
                msgspec.json.encode(identity).decode(),
                fingerprint(identity),
                now,
                by,
            ),
        )
        audit.append(
            conn,
            action="peer.enrol",
            user_id=None,
            device_id=None,
            kind="peer",
            record_id=identity.site_id,
            detail=f"{identity.role.value} {identity.name!r}, fingerprint {fingerprint(identity)}, by {by}",
        )
        return _peer(_row(conn, identity.site_id))


def revoke(db: Database, site_id: str, *, reason: str, by: str) -> Peer:
    """Stop trusting a site: everything it signs from now on is rejected; what it sent before stays readable."""
    with db.write() as conn:
        _row(conn, site_id)
        conn.execute(
            "UPDATE peers SET revoked_at = ?, revoke_reason = ? WHERE site_id = ?",
            (iso(utcnow()), reason or "no reason given", site_id),
        )
        audit.append(
            conn,
            action="peer.revoke",
            user_id=None,
            device_id=None,
            kind="peer",
            record_id=site_id,
            detail=f"by {by}: {reason}",
        )
        return _peer(_row(conn, site_id))


def list_peers(db: Database) -> list[Peer]:
    return [_peer(r) for r in db.connection().execute("SELECT * FROM peers ORDER BY site_id")]


def trusted(conn: sqlite3.Connection, site_id: str, role: SiteRole) -> SiteIdentity:
    """The keys of an enrolled, unrevoked site of that role; TransferRejected otherwise."""
    row = conn.execute("SELECT * FROM peers WHERE site_id = ?", (site_id,)).fetchone()
    if row is None:
        raise TransferRejected(f"{site_id} is not an enrolled site", code="unknown-site")
    if row["revoked_at"] is not None:
        raise TransferRejected(
            f"{site_id} was revoked on {row['revoked_at']}: {row['revoke_reason']}", code="revoked-site"
        )
    if row["role"] != role.value:
        raise TransferRejected(f"{site_id} is enrolled as a {row['role']}, not a {role.value}", code="wrong-role")
    return msgspec.json.decode(row["identity"], type=SiteIdentity)


def only_center(conn: sqlite3.Connection, wanted: str = "") -> SiteIdentity:
    """The center to send to: `wanted`, or the one enrolled center."""
    if wanted:
        return trusted(conn, wanted, SiteRole.center)
    rows = conn.execute("SELECT site_id FROM peers WHERE role = 'center' AND revoked_at IS NULL").fetchall()
    if len(rows) != 1:
        raise NotFound(
            f"{len(rows)} burn centers are enrolled: enrol one (`burnedge peers enrol center.pub.json`)"
            " or name it in [sync] center_id"
        )
    return trusted(conn, rows[0]["site_id"], SiteRole.center)


def _row(conn: sqlite3.Connection, site_id: str) -> sqlite3.Row:
    row = conn.execute("SELECT * FROM peers WHERE site_id = ?", (site_id,)).fetchone()
    if row is None:
        raise NotFound(f"no enrolled site is called {site_id}")
    return row


def _peer(row: sqlite3.Row) -> Peer:
    return Peer(
        identity=msgspec.json.decode(row["identity"], type=SiteIdentity),
        fingerprint=row["fingerprint"],
        enrolled_at=row["enrolled_at"],
        enrolled_by=row["enrolled_by"],
        revoked_at=row["revoked_at"],
        revoke_reason=row["revoke_reason"],
    )
