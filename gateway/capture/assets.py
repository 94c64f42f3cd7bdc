"""Stored photos, videos and frames: checking a finished upload and recording it as an asset."""

from __future__ import annotations

import base64
import binascii
import hashlib
import json
import os
import sqlite3
from pathlib import Path

from base.accounts.permissions import Principal, require_capture, require_read
from base.storage import assets as asset_rows
from base.storage import audit
from base.storage.blobs import MediaStore, sha256_of
from base.storage.records import get_head
from gateway.records.validation import bad_field, require_live_encounter
from gateway.storage import uploads as upload_rows
from gateway.storage.database import Database
from gateway.wounds.choice import wound_of_patient
from processing.capture.media import check_photo, check_video, sniff
from processing.capture.phone_time import with_stated_time
from processing.capture.quality import gate_bytes
from processing.capture.readiness import View
from processing.capture.readiness import assess as assess_readiness
from schemas.base import iso, utcnow
from schemas.capture import Asset, AssetKind, CaptureMetadata, CaptureReadiness, MediaType, QualityVerdict, SetAside
from schemas.config import Config
from schemas.errors import ChecksumMismatch, InvalidInput, PayloadTooLarge
from schemas.ids import uuid7
from schemas.records import RecordKind


class AssetService:
    def __init__(self, db: Database, config: Config, store: MediaStore):
        self.db, self.config, self.store = db, config, store

    def store_upload(
        self,
        principal: Principal,
        encounter_id: str,
        part: Path,
        filename: str,
        *,
        upload_id: str | None = None,
        expected: str | None = None,
        wound_id: str | None = None,
        stated_time: str | None = None,
    ) -> Asset:
        """Check a finished upload and keep it; the same bytes for the same encounter give the same asset.

        Everything is checked before the file moves into the store; the asset row and the
        upload's completion are written in one transaction. `expected` is an optional
        whole-file checksum from the upload's metadata ("sha256 <hex or base64>"); `stated_time` the capture time
        the phone stated there (ISO 8601 with offset), kept when the file carries none.
        """
        size = part.stat().st_size
        if size == 0:
            raise InvalidInput("the file is empty")
        with open(part, "rb") as f:
            media_type = sniff(f.read(32))
        with self.db.read() as conn:
            require_live_encounter(conn, encounter_id)
        if media_type.is_video:
            limits = self.config
            metadata = check_video(part, limits=limits.quality, max_seconds=limits.uploads.max_video_seconds)
            kind, verdict = AssetKind.video, None
            sha = sha256_of(part)
        else:
            if size > self.config.uploads.max_photo_bytes:
                raise PayloadTooLarge(
                    f"a {size // 1024**2} MB photo is over the {self.config.uploads.max_photo_bytes // 1024**2} MB"
                    " limit: phones write 2-30 MB; send the camera's original, not a scan"
                )
            data = part.read_bytes()
            metadata, kind = check_photo(data, media_type, self.config.quality.max_pixels), AssetKind.photo
            verdict = gate_bytes(data, self.config.quality, name=filename)
            sha = hashlib.sha256(data).hexdigest()
        metadata = with_stated_time(metadata, stated_time)
        _check_whole_file(expected, sha)
        new_blob = not self.store.blob(sha).exists()
        final = self.store.promote(part, sha)
        try:
            return self._insert(
                principal,
                encounter_id,
                kind,
                media_type,
                sha,
                size,
                filename,
                metadata,
                verdict,
                None,
                upload_id=upload_id,
                wound_id=wound_id,
            )
        except BaseException:
            if new_blob:
                os.replace(final, part)  # back where it was: the upload can still be completed later
            raise

    def _insert(
        self,
        principal: Principal,
        encounter_id: str,
        kind: AssetKind,
        media_type: MediaType,
        sha: str,
        size: int,
        filename: str,
        metadata: CaptureMetadata,
        verdict: QualityVerdict | None,
        source_asset_id: str | None,
        *,
        upload_id: str | None = None,
        wound_id: str | None = None,
    ) -> Asset:
        with self.db.write() as conn:
            encounter = require_live_encounter(conn, encounter_id)
            if wound_id is not None:
                wound_of_patient(conn, encounter.value().patient_id, wound_id, "Upload-Metadata wound_id")
            asset_id = insert_asset_row(
                conn,
                principal,
                encounter_id,
                kind,
                media_type,
                sha,
                size,
                filename,
                metadata,
                verdict,
                source_asset_id,
                wound_id=wound_id,
            )
            if upload_id is not None:
                upload_rows.mark_upload_complete(conn, upload_id, asset_id)
            return asset_rows.get_asset(conn, asset_id)

    def get(self, principal: Principal, asset_id: str) -> Asset:
        require_read(principal, RecordKind.encounter)
        return asset_rows.get_asset(self.db.connection(), asset_id)

    def set_wound(self, principal: Principal, asset_id: str, wound_id: str | None) -> Asset:
        """Say which wound a picture shows (a video's frames follow it); None says no wound in particular."""
        require_capture(principal)
        with self.db.write() as conn:
            asset = asset_rows.get_asset(conn, asset_id)
            encounter = require_live_encounter(conn, asset.encounter_id)
            if asset.source_asset_id is not None:
                raise InvalidInput(f"{asset.filename} is a frame of a video: set the wound of the video instead")
            if wound_id is not None:
                wound_of_patient(conn, encounter.value().patient_id, wound_id, "$.wound_id")
            if asset.wound_id != wound_id:
                asset_rows.set_asset_wound(conn, asset_id, wound_id)
                audit.append(
                    conn,
                    action="asset.wound",
                    user_id=principal.user_id,
                    device_id=principal.device_id,
                    kind="asset",
                    record_id=asset_id,
                    detail=json.dumps({"from": asset.wound_id, "to": wound_id}),
                )
            return asset_rows.get_asset(conn, asset_id)

    def set_aside(self, principal: Principal, asset_id: str, reason: str | None) -> Asset:
        """Set a picture aside with the reason (None puts it back): it no longer counts for readiness, analyses
        or the case sent; nothing is deleted. A video's frames follow it; a frame alone can be set aside."""
        require_capture(principal)
        with self.db.write() as conn:
            asset = asset_rows.get_asset(conn, asset_id)
            require_live_encounter(conn, asset.encounter_id)
            if reason is not None and not reason.strip():
                raise bad_field("$.reason", "say why the picture should not count")
            aside = SetAside(reason=reason.strip(), by=principal.username, at=utcnow()) if reason else None
            if (asset.set_aside is None) != (aside is None):
                asset_rows.set_asset_aside(conn, asset_id, aside)
                audit.append(
                    conn,
                    action="asset.set_aside" if aside else "asset.put_back",
                    user_id=principal.user_id,
                    device_id=principal.device_id,
                    kind="asset",
                    record_id=asset_id,
                    detail=aside.reason if aside else asset.set_aside.reason,
                )
            return asset_rows.get_asset(conn, asset_id)

    def for_encounter(self, principal: Principal, encounter_id: str) -> list[Asset]:
        require_read(principal, RecordKind.encounter)
        conn = self.db.connection()
        get_head(conn, RecordKind.encounter, encounter_id)  # an unknown encounter is a 404, not an empty list
        return asset_rows.assets_of_encounter(conn, encounter_id)

    def readiness(self, principal: Principal, encounter_id: str) -> CaptureReadiness:
        """Whether the encounter's photos and frames are enough for 3D analysis."""
        require_read(principal, RecordKind.encounter)
        with self.db.read() as conn:
            require_live_encounter(conn, encounter_id)
        views = [
            View(verdict=a.verdict, focal_35mm=a.metadata.focal_length_35mm)
            for a in self.for_encounter(principal, encounter_id)
            if a.verdict is not None and a.set_aside is None
        ]
        return assess_readiness(views, self.config.readiness, self.config.quality)

    def file(self, principal: Principal, asset_id: str) -> tuple[Asset, Path]:
        asset = self.get(principal, asset_id)
        return asset, self.store.blob(asset.sha256)


def _check_whole_file(expected: str | None, sha256_hex: str) -> None:
    """Compare with the whole-file checksum the phone sent in Upload-Metadata, if it sent one."""
    if not expected:
        return
    algo, _, value = expected.strip().partition(" ")
    if algo.lower() != "sha256":
        raise InvalidInput(f"whole-file checksum {algo!r} is not supported: send 'sha256 <hex or base64>'")
    digest = bytes.fromhex(sha256_hex)
    try:
        given = bytes.fromhex(value) if len(value) == 64 else base64.b64decode(value, validate=True)
    except (ValueError, binascii.Error) as exc:
        raise InvalidInput("the whole-file checksum is neither hex nor base64") from exc
    if given != digest:
        raise ChecksumMismatch("the file received does not match the checksum the phone sent for it: upload it again")


def insert_asset_row(
    conn: sqlite3.Connection,
    principal: Principal,
    encounter_id: str,
    kind: AssetKind,
    media_type: MediaType,
    sha: str,
    size: int,
    filename: str,
    metadata: CaptureMetadata,
    verdict: QualityVerdict | None,
    source_asset_id: str | None,
    *,
    wound_id: str | None = None,
) -> str:
    """One asset row and its audit entry, inside the caller's transaction; returns its id.

    The same bytes already stored for this encounter (a retry, two uploads finishing together,
    a frame identical to a photo) keep their existing asset (which takes the wound if it had none).
    """
    existing = asset_rows.asset_id_with_bytes(conn, encounter_id, sha)
    if existing is not None:
        if wound_id is not None and asset_rows.get_asset(conn, existing).wound_id is None:
            asset_rows.set_asset_wound(conn, existing, wound_id)
        return existing
    asset = Asset(
        id=uuid7(),
        encounter_id=encounter_id,
        kind=kind,
        media_type=media_type,
        sha256=sha,
        size_bytes=size,
        filename=filename,
        metadata=metadata,
        verdict=verdict,
        source_asset_id=source_asset_id,
        created_at=iso(utcnow()),
        created_by=principal.username,
        device_id=principal.device_id,
        wound_id=wound_id,
    )
    asset_rows.insert_asset(conn, asset)
    audit.append(
        conn,
        action="asset.create",
        user_id=principal.user_id,
        device_id=principal.device_id,
        kind="asset",
        record_id=asset.id,
        detail=json.dumps({"sha256": sha, "encounter": encounter_id, "wound": wound_id}),
    )
    return asset.id
