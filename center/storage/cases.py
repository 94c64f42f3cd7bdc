"""Rows of stored bundles (`bundles`, `bundle_parts`): each version of a clinic's case, its parts and its receipt,
and the consultants' view of them as cases."""

from __future__ import annotations

import itertools
import sqlite3

import msgspec

from schemas.central import CaseItem, SealedAtRest, StoredBundle, StoredCase, StoredPart
from schemas.transfer import (
    URGENCY_ORDER,
    BundleManifest,
    CaseSummary,
    SignedEnvelope,
    SiteIdentity,
    Urgency,
)

_envelope = msgspec.msgpack.Decoder(SignedEnvelope)


_CASE_COLUMNS = """b.site_id, b.bundle_id, b.encounter_id, b.patient_id, b.version, b.urgency, b.summary,
    b.stored_at, b.superseded_by, b.advised, p.identity AS peer_identity,
    (SELECT COUNT(*) FROM notes t WHERE t.site_id = b.site_id AND t.encounter_id = b.encounter_id) AS notes"""
CASE_SQL = f"SELECT {_CASE_COLUMNS} FROM bundles b JOIN peers p ON p.site_id = b.site_id"
"""The columns case_item() reads, for a WHERE and ORDER BY on `b` (bundles) to follow."""
_SUPERSEDE = (
    "UPDATE bundles SET superseded_by = (SELECT n.bundle_id FROM bundles n WHERE n.site_id = bundles.site_id"
    " AND n.encounter_id = bundles.encounter_id AND n.version > bundles.version ORDER BY n.version DESC LIMIT 1)"
    " WHERE site_id = ? AND encounter_id = ?"
)
_FLAG_SUPERSEDED = (
    "UPDATE bundles SET superseded = CASE WHEN superseded_by IS NULL THEN 0 ELSE 1 END"
    " WHERE site_id = ? AND encounter_id = ?"
)
_ADVISED_ALREADY = (
    "UPDATE bundles SET advised = 1 WHERE site_id = ? AND bundle_id = ? AND EXISTS (SELECT 1 FROM notes t"
    " WHERE t.site_id = bundles.site_id AND t.encounter_id = bundles.encounter_id AND t.written_at >= bundles.stored_at)"
)


def case_item(row: sqlite3.Row) -> CaseItem:
    """A row of CASE_SQL as the consultants' list shows it."""
    identity = msgspec.json.decode(row["peer_identity"], type=SiteIdentity)
    return CaseItem(
        site_id=row["site_id"],
        site_name=identity.name,
        bundle_id=row["bundle_id"],
        encounter_id=row["encounter_id"],
        patient_id=row["patient_id"],
        version=row["version"],
        urgency=Urgency(row["urgency"]),
        summary=msgspec.json.decode(row["summary"], type=CaseSummary),
        stored_at=row["stored_at"],
        superseded_by=row["superseded_by"],
        notes=row["notes"],
        awaiting_advice=not row["advised"],
    )


def find_case(conn: sqlite3.Connection, site_id: str, bundle_id: str) -> StoredCase | None:
    """The case this bundle holds, with its manifest, or None when no such bundle is stored."""
    row = conn.execute(
        f"SELECT {_CASE_COLUMNS}, b.manifest FROM bundles b JOIN peers p ON p.site_id = b.site_id"
        " WHERE b.site_id = ? AND b.bundle_id = ?",
        (site_id, bundle_id),
    ).fetchone()
    if row is None:
        return None
    return StoredCase(case=case_item(row), manifest=msgspec.json.decode(row["manifest"], type=BundleManifest))


def case_versions(conn: sqlite3.Connection, site_id: str, encounter_id: str) -> list[CaseItem]:
    """Every stored version of the encounter's case, newest first."""
    rows = conn.execute(
        CASE_SQL + " WHERE b.site_id = ? AND b.encounter_id = ? ORDER BY b.version DESC", (site_id, encounter_id)
    ).fetchall()
    return [case_item(r) for r in rows]


def _bundle(row: sqlite3.Row) -> StoredBundle:
    return StoredBundle(
        site_id=row["site_id"],
        bundle_id=row["bundle_id"],
        encounter_id=row["encounter_id"],
        patient_id=row["patient_id"],
        version=row["version"],
        manifest_sha256=row["manifest_sha256"],
        stored_at=row["stored_at"],
    )


def find_bundle(conn: sqlite3.Connection, site_id: str, bundle_id: str) -> StoredBundle | None:
    """The stored bundle, or None when the site has none with this id."""
    row = conn.execute("SELECT * FROM bundles WHERE site_id = ? AND bundle_id = ?", (site_id, bundle_id)).fetchone()
    return _bundle(row) if row else None


def latest_of_encounter(conn: sqlite3.Connection, site_id: str, encounter_id: str) -> StoredBundle | None:
    """The highest version stored of the site's encounter, or None when none is."""
    row = conn.execute(
        "SELECT * FROM bundles WHERE site_id = ? AND encounter_id = ? ORDER BY version DESC LIMIT 1",
        (site_id, encounter_id),
    ).fetchone()
    return _bundle(row) if row else None


def find_receipt(conn: sqlite3.Connection, site_id: str, bundle_id: str) -> SignedEnvelope | None:
    """The signed receipt the center gave for this bundle, or None when it is not stored."""
    row = conn.execute(
        "SELECT receipt FROM bundles WHERE site_id = ? AND bundle_id = ?", (site_id, bundle_id)
    ).fetchone()
    return None if row is None else _envelope.decode(row["receipt"])


def find_part(conn: sqlite3.Connection, site_id: str, bundle_id: str, name: str) -> StoredPart | None:
    """Where the stored bundle's file of this name is, or None when it has none."""
    row = conn.execute(
        "SELECT p.*, b.sealed_key, b.chunks, b.chunk_bytes FROM bundle_parts p JOIN bundles b ON b.site_id = p.site_id"
        " AND b.bundle_id = p.bundle_id WHERE p.site_id = ? AND p.bundle_id = ? AND p.name = ?",
        (site_id, bundle_id, name),
    ).fetchone()
    if row is None:
        return None
    return StoredPart(
        name=row["name"],
        media_type=row["media_type"],
        sha256=row["sha256"],
        size=row["size"],
        sealed_key=bytes(row["sealed_key"]) if row["sealed_key"] is not None else None,
        chunks=row["chunks"] or 0,
        chunk_bytes=row["chunk_bytes"] or 0,
        plain_offset=row["plain_offset"],
    )


def insert_bundle(
    conn: sqlite3.Connection,
    site_id: str,
    manifest: BundleManifest,
    *,
    manifest_sha256: str,
    stored_at: str,
    receipt: SignedEnvelope,
    sealed: SealedAtRest | None = None,
) -> None:
    """Store a bundle version and its parts' rows, and mark the versions it replaces. DuplicateRow when the site
    already stored this version of the encounter from another bundle. `sealed`: where its files are in the chunks
    kept as received (None: stored as plain files)."""
    conn.execute(
        "INSERT INTO bundles (site_id, bundle_id, encounter_id, patient_id, version, supersedes, urgency,"
        " urgency_rank, summary, manifest, manifest_sha256, stored_at, receipt, sealed_key, chunks, chunk_bytes)"
        " VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?)",
        (
            site_id,
            manifest.bundle_id,
            manifest.encounter_id,
            manifest.patient_id,
            manifest.version,
            manifest.supersedes,
            manifest.summary.urgency.value,
            URGENCY_ORDER[manifest.summary.urgency],
            msgspec.json.encode(manifest.summary).decode(),
            msgspec.json.encode(manifest).decode(),
            manifest_sha256,
            stored_at,
            msgspec.msgpack.encode(receipt),
            sealed.sealed_key if sealed else None,
            sealed.chunks if sealed else None,
            sealed.chunk_bytes if sealed else None,
        ),
    )
    offsets = itertools.accumulate((p.size for p in manifest.parts), initial=sealed.parts_offset if sealed else 0)
    conn.executemany(
        "INSERT INTO bundle_parts (site_id, bundle_id, name, media_type, sha256, size, plain_offset)"
        " VALUES (?,?,?,?,?,?,?)",
        [
            (site_id, manifest.bundle_id, p.name, p.media_type, p.sha256, p.size, offset if sealed else None)
            for p, offset in zip(manifest.parts, offsets, strict=False)
        ],
    )
    conn.execute(_SUPERSEDE, (site_id, manifest.encounter_id))
    conn.execute(_FLAG_SUPERSEDED, (site_id, manifest.encounter_id))
    conn.execute(_ADVISED_ALREADY, (site_id, manifest.bundle_id))
