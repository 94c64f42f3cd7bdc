"""The assets table: stored photos, videos and frames, their videos' frame progress, and the photos a case bundle
carries. The gateway's intake writes it; replication reads it (so it is shared, below both).

Knows SQL, not capture rules: the services decide what to store and write the audit entries, in the same
transaction, through the connection they pass in.
"""

from __future__ import annotations

import sqlite3
from dataclasses import dataclass

import msgspec

from schemas.base import iso, utcnow
from schemas.capture import Asset, AssetKind, CaptureMetadata, MediaType, QualityVerdict, SetAside
from schemas.errors import NotFound

_verdict = msgspec.json.Decoder(QualityVerdict)
_set_aside = msgspec.json.Decoder(SetAside)
_metadata = msgspec.json.Decoder(CaptureMetadata)


@dataclass(frozen=True)
class FramesProgress:
    """Where a video's frame extraction stands."""

    done_at: str | None
    """When its frames were stored (or it was given up on); None while pending."""
    error: str | None
    """Why the last extraction failed, if it did."""


# assets ------------------------------------------------------------------------------------


def _asset(row: sqlite3.Row) -> Asset:
    return Asset(
        id=row["id"],
        encounter_id=row["encounter_id"],
        kind=AssetKind(row["kind"]),
        media_type=MediaType(row["media_type"]),
        sha256=row["sha256"],
        size_bytes=row["size_bytes"],
        filename=row["filename"],
        metadata=_metadata.decode(row["metadata"]),
        verdict=_verdict.decode(row["verdict"]) if row["verdict"] else None,
        source_asset_id=row["source_asset_id"],
        created_at=row["created_at"],
        created_by=row["created_by"],
        device_id=row["device_id"],
        wound_id=row["wound_id"],
        set_aside=_set_aside.decode(row["set_aside"]) if row["set_aside"] else None,
    )


def get_asset(conn: sqlite3.Connection, asset_id: str) -> Asset:
    """The asset with this id; NotFound if there is none."""
    row = conn.execute("SELECT * FROM assets WHERE id = ?", (asset_id,)).fetchone()
    if row is None:
        raise NotFound(f"no asset {asset_id}")
    return _asset(row)


def assets_of_encounter(conn: sqlite3.Connection, encounter_id: str) -> list[Asset]:
    """The encounter's assets, oldest first."""
    rows = conn.execute("SELECT * FROM assets WHERE encounter_id = ? ORDER BY created_at, id", (encounter_id,))
    return [_asset(r) for r in rows.fetchall()]


def asset_id_with_bytes(conn: sqlite3.Connection, encounter_id: str, sha256: str) -> str | None:
    """The id of the encounter's asset holding these bytes, or None when the encounter has none with them."""
    row = conn.execute("SELECT id FROM assets WHERE encounter_id = ? AND sha256 = ?", (encounter_id, sha256)).fetchone()
    return None if row is None else row["id"]


def insert_asset(conn: sqlite3.Connection, asset: Asset) -> None:
    """Write a new asset row, inside the caller's transaction."""
    conn.execute(
        "INSERT INTO assets (id, encounter_id, kind, media_type, sha256, size_bytes, filename, metadata, verdict,"
        " source_asset_id, created_at, created_by, device_id, wound_id) VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?)",
        (
            asset.id,
            asset.encounter_id,
            asset.kind.value,
            asset.media_type.value,
            asset.sha256,
            asset.size_bytes,
            asset.filename,
            msgspec.json.encode(asset.metadata).decode(),
            msgspec.json.encode(asset.verdict).decode() if asset.verdict else None,
            asset.source_asset_id,
            asset.created_at,
            asset.created_by,
            asset.device_id,
            asset.wound_id,
        ),
    )


def set_asset_wound(conn: sqlite3.Connection, asset_id: str, wound_id: str | None) -> None:
    """Say which wound a picture (and the frames taken from it) shows, inside the caller's transaction."""
    conn.execute("UPDATE assets SET wound_id = ? WHERE id = ? OR source_asset_id = ?", (wound_id, asset_id, asset_id))


def set_asset_aside(conn: sqlite3.Connection, asset_id: str, set_aside: SetAside | None) -> None:
    """Set a picture (and a video's frames) aside, or put it back (None), inside the caller's transaction."""
    text = msgspec.json.encode(set_aside).decode() if set_aside is not None else None
    conn.execute("UPDATE assets SET set_aside = ? WHERE id = ? OR source_asset_id = ?", (text, asset_id, asset_id))


# frames of videos --------------------------------------------------------------------------


def pending_video_ids(conn: sqlite3.Connection) -> list[str]:
    """Ids of the videos whose frames are not stored yet, oldest first."""
    rows = conn.execute(
        "SELECT id FROM assets WHERE kind = 'video' AND frames_done_at IS NULL ORDER BY created_at"
    ).fetchall()
    return [r["id"] for r in rows]


def find_frames_progress(conn: sqlite3.Connection, video_id: str) -> FramesProgress | None:
    """Where the video's frame extraction stands; None when there is no such asset."""
    row = conn.execute("SELECT frames_done_at, frames_error FROM assets WHERE id = ?", (video_id,)).fetchone()
    return None if row is None else FramesProgress(done_at=row["frames_done_at"], error=row["frames_error"])


def set_frames_error(conn: sqlite3.Connection, video_id: str, error: str) -> None:
    """Remember why an extraction failed, leaving the video pending."""
    conn.execute("UPDATE assets SET frames_error = ? WHERE id = ?", (error, video_id))


def set_frames_done(conn: sqlite3.Connection, video_id: str, error: str | None) -> None:
    """Mark a pending video done now, with the reason if its frames were given up on; a done video stays as it is."""
    conn.execute(
        "UPDATE assets SET frames_done_at = ?, frames_error = ? WHERE id = ? AND frames_done_at IS NULL",
        (iso(utcnow()), error, video_id),
    )


class EncounterPhoto(msgspec.Struct, frozen=True, kw_only=True):
    """A photo stored for an encounter, as far as sending it needs: which blob holds it and its media type."""

    id: str
    sha256: str
    """Of the bytes: the name of the blob in the media store."""
    media_type: str


def encounter_photos(conn: sqlite3.Connection, encounter_id: str, limit: int) -> list[EncounterPhoto]:
    """The encounter's photos in the order they were taken in (up to `limit`), not its videos or frames, nor
    those set aside."""
    rows = conn.execute(
        "SELECT id, sha256, media_type FROM assets WHERE encounter_id = ? AND kind = 'photo' AND set_aside IS NULL"
        " ORDER BY created_at, id LIMIT ?",
        (encounter_id, limit),
    ).fetchall()
    return [EncounterPhoto(id=r["id"], sha256=r["sha256"], media_type=r["media_type"]) for r in rows]
