"""The sites a site trusts: enrolled with their public keys, revocable, every change audited."""

from __future__ import annotations

import sqlite3

from base.storage import audit
from base.storage.postgres import AnyDatabase
from schemas.base import iso, utcnow
from schemas.errors import Conflict, NotFound, TransferRejected
from schemas.transfer import Peer, SiteIdentity, SiteRole
from sync.keys import check_identity, fingerprint
from sync.storage import peers as store


def enrol(db: AnyDatabase, identity: SiteIdentity, *, by: str, replace: bool = False) -> Peer:
    """Trust `identity`; an enrolled site's keys are only replaced with `replace` (after the site made new keys)."""
    check_identity(identity)
    now = iso(utcnow())
    with db.write() as conn:
        known = store.find(conn, identity.site_id)
        if known is not None and not replace and known.identity != identity:
            raise Conflict(
                f"{identity.site_id} is already enrolled with other keys: check the fingerprint with the "
                "site, then enrol again with --replace"
            )
        store.upsert(conn, identity, fingerprint=fingerprint(identity), at=now, by=by)
        audit.append(
            conn,
            action="peer.enrol",
            user_id=None,
            device_id=None,
            kind="peer",
            record_id=identity.site_id,
            detail=f"{identity.role.value} {identity.name!r}, fingerprint {fingerprint(identity)}, by {by}",
        )
        return store.get(conn, identity.site_id)


def revoke(db: AnyDatabase, site_id: str, *, reason: str, by: str) -> Peer:
    """Stop trusting a site: everything it signs from now on is rejected; what it sent before stays readable."""
    with db.write() as conn:
        store.get(conn, site_id)
        store.set_revoked(conn, site_id, at=iso(utcnow()), reason=reason or "no reason given")
        audit.append(
            conn,
            action="peer.revoke",
            user_id=None,
            device_id=None,
            kind="peer",
            record_id=site_id,
            detail=f"by {by}: {reason}",
        )
        return store.get(conn, site_id)


def list_peers(db: AnyDatabase) -> list[Peer]:
    return store.list_all(db.connection())


def trusted(conn: sqlite3.Connection, site_id: str, role: SiteRole) -> SiteIdentity:
    """The keys of an enrolled, unrevoked site of that role; TransferRejected otherwise."""
    peer = store.find(conn, site_id)
    if peer is None:
        raise TransferRejected(f"{site_id} is not an enrolled site", code="unknown-site")
    if peer.revoked_at is not None:
        raise TransferRejected(f"{site_id} was revoked on {peer.revoked_at}: {peer.revoke_reason}", code="revoked-site")
    if peer.identity.role is not role:
        raise TransferRejected(
            f"{site_id} is enrolled as a {peer.identity.role.value}, not a {role.value}", code="wrong-role"
        )
    return peer.identity


def only_center(conn: sqlite3.Connection, wanted: str = "") -> SiteIdentity:
    """The center to send to: `wanted`, or the one enrolled center."""
    if wanted:
        return trusted(conn, wanted, SiteRole.center)
    centers = store.unrevoked_ids(conn, SiteRole.center)
    if len(centers) != 1:
        raise NotFound(
            f"{len(centers)} burn centers are enrolled: the administrator enrols one on the Burn center page, step 2"
            " (from a shell, `burnedge peers enrol center.pub.json`), or names one in [sync] center_id"
        )
    return trusted(conn, centers[0], SiteRole.center)
