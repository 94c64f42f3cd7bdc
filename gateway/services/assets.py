"""Stored photos, videos and frames: checking a finished upload and recording it as an asset."""

from __future__ import annotations

import json
from pathlib import Path

import msgspec

from gateway.services.permissions import Principal, require_read
from gateway.services.validation import require_live_encounter
from gateway.storage import audit
from gateway.storage.blobs import MediaStore, sha256_of
from gateway.storage.database import Database
from processing.capture.media import check_photo, check_video, sniff
from processing.capture.quality import gate_file
from processing.capture.readiness import View
from processing.capture.readiness import assess as assess_readiness
from schemas.base import iso, utcnow
from schemas.capture import Asset, AssetKind, CaptureMetadata, CaptureReadiness, MediaType, QualityVerdict
from schemas.config import Config
from schemas.errors import InvalidInput, NotFound
from schemas.ids import uuid7
from schemas.records import RecordKind

_verdict = msgspec.json.Decoder(QualityVerdict)
_metadata = msgspec.json.Decoder(CaptureMetadata)


def _asset(row) -> Asset:
    return Asset(
        id=row["id"], encounter_id=row["encounter_id"], kind=AssetKind(row["kind"]),
        media_type=MediaType(row["media_type"]), sha256=row["sha256"], size_bytes=row["size_bytes"],
        filename=row["filename"], metadata=_metadata.decode(row["metadata"]),
        verdict=_verdict.decode(row["verdict"]) if row["verdict"] else None, source_asset_id=row["source_asset_id"],
        created_at=row["created_at"], created_by=row["created_by"], device_id=row["device_id"],
    )  # fmt: skip


class AssetService:
    def __init__(self, db: Database, config: Config, store: MediaStore):
        self.db, self.config, self.store = db, config, store

    def store_upload(self, principal: Principal, encounter_id: str, part: Path, filename: str) -> Asset:
        """Check a finished upload and keep it; the same bytes for the same encounter give the same asset."""
        size = part.stat().st_size
        if size == 0:
            raise InvalidInput("the file is empty")
        with open(part, "rb") as f:
            media_type = sniff(f.read(32))
        if media_type.is_video:
            metadata, kind = check_video(part), AssetKind.video
        else:
            metadata, kind = check_photo(part, media_type, self.config.quality.max_pixels), AssetKind.photo
        sha = sha256_of(part)
        existing = self._find(encounter_id, sha)
        if existing is not None:
            part.unlink()
            return existing
        final = self.store.promote(part, sha)
        verdict = None if media_type.is_video else gate_file(final, self.config.quality)
        if verdict is not None:
            verdict = msgspec.structs.replace(verdict, file=filename)
        return self._insert(principal, encounter_id, kind, media_type, sha, size, filename, metadata, verdict, None)

    def _insert(self, principal: Principal, encounter_id: str, kind: AssetKind, media_type: MediaType, sha: str,
                size: int, filename: str, metadata: CaptureMetadata, verdict: QualityVerdict | None,
                source_asset_id: str | None) -> Asset:  # fmt: skip
        asset_id = uuid7()
        with self.db.write() as conn:
            require_live_encounter(conn, encounter_id)
            # Two uploads of the same bytes finishing together: the second finds the first's row.
            existing = conn.execute(
                "SELECT * FROM assets WHERE encounter_id = ? AND sha256 = ?", (encounter_id, sha)
            ).fetchone()
            if existing is not None:
                return _asset(existing)
            conn.execute(
                "INSERT INTO assets (id, encounter_id, kind, media_type, sha256, size_bytes, filename, metadata, verdict,"
                " source_asset_id, created_at, created_by, device_id) VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?)",
                (asset_id, encounter_id, kind.value, media_type.value, sha, size, filename,
                 msgspec.json.encode(metadata).decode(), msgspec.json.encode(verdict).decode() if verdict else None,
                 source_asset_id, iso(utcnow()), principal.username, principal.device_id),
            )  # fmt: skip
            audit.append(conn, action="asset.create", user_id=principal.user_id, device_id=principal.device_id,
                         kind="asset", record_id=asset_id, detail=json.dumps({"sha256": sha, "encounter": encounter_id}))  # fmt: skip
            return _asset(conn.execute("SELECT * FROM assets WHERE id = ?", (asset_id,)).fetchone())

    def add_derived(self, principal: Principal, source: Asset, kind: AssetKind, media_type: MediaType, sha: str,
                    size: int, filename: str, metadata: CaptureMetadata, verdict: QualityVerdict | None) -> Asset:  # fmt: skip
        """An asset the gateway made from another (a frame from its video); the same bytes once per encounter."""
        existing = self._find(source.encounter_id, sha)
        if existing is not None:
            return existing
        return self._insert(principal, source.encounter_id, kind, media_type, sha, size, filename, metadata, verdict,
                            source.id)  # fmt: skip

    def _find(self, encounter_id: str, sha: str) -> Asset | None:
        row = (
            self.db.connection()
            .execute("SELECT * FROM assets WHERE encounter_id = ? AND sha256 = ?", (encounter_id, sha))
            .fetchone()
        )
        return _asset(row) if row else None

    def get(self, principal: Principal, asset_id: str) -> Asset:
        require_read(principal, RecordKind.encounter)
        row = self.db.connection().execute("SELECT * FROM assets WHERE id = ?", (asset_id,)).fetchone()
        if row is None:
            raise NotFound(f"no asset {asset_id}")
        return _asset(row)

    def for_encounter(self, principal: Principal, encounter_id: str) -> list[Asset]:
        require_read(principal, RecordKind.encounter)
        rows = (
            self.db.connection()
            .execute("SELECT * FROM assets WHERE encounter_id = ? ORDER BY created_at, id", (encounter_id,))
            .fetchall()
        )
        return [_asset(r) for r in rows]

    def readiness(self, principal: Principal, encounter_id: str) -> CaptureReadiness:
        """Whether the encounter's photos and frames are enough for 3D analysis."""
        require_read(principal, RecordKind.encounter)
        with self.db.read() as conn:
            require_live_encounter(conn, encounter_id)
        views = [
            View(verdict=a.verdict, focal_35mm=a.metadata.focal_length_35mm)
            for a in self.for_encounter(principal, encounter_id)
            if a.verdict is not None
        ]
        return assess_readiness(views, self.config.readiness, self.config.quality)

    def file(self, principal: Principal, asset_id: str) -> tuple[Asset, Path]:
        asset = self.get(principal, asset_id)
        return asset, self.store.blob(asset.sha256)
