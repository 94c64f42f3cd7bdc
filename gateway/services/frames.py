"""Frames from uploaded videos, stored as assets linked to their video.

A video asset is done once its frames are stored (frames_done_at). Pending videos are
picked up after each video upload and by the scheduler, so a gateway restarted in the
middle of an extraction finishes it later; the frames of one video are stored together.
"""

from __future__ import annotations

import logging

import msgspec

from gateway.services.assets import AssetService
from gateway.services.permissions import Principal
from gateway.storage.database import Database
from processing.capture.frames import extract
from schemas.accounts import Role
from schemas.base import iso, utcnow
from schemas.capture import Asset, AssetKind, CaptureMetadata, MediaType
from schemas.config import Config
from schemas.errors import BurnedgeError

log = logging.getLogger("burnedge.frames")
GATEWAY = Principal(user_id="gateway", username="gateway", role=Role.clinician, device_id=None, session_hash="")
"""The gateway itself, as the author of the frames it extracts."""


class FrameService:
    def __init__(self, db: Database, config: Config, assets: AssetService):
        self.db, self.config, self.assets = db, config, assets

    def pending(self) -> list[str]:
        rows = (
            self.db.connection()
            .execute("SELECT id FROM assets WHERE kind = 'video' AND frames_done_at IS NULL ORDER BY created_at")
            .fetchall()
        )
        return [r["id"] for r in rows]

    def extract_pending(self) -> int:
        done = 0
        for asset_id in self.pending():
            self.extract_one(asset_id)
            done += 1
        return done

    def extract_one(self, video_id: str) -> list[Asset]:
        video = self.assets.get(GATEWAY, video_id)
        path = self.assets.store.blob(video.sha256)
        try:
            result = extract(path, self.config.frames, self.config.quality, name=video.filename)
        except BurnedgeError as exc:
            log.warning("no frames from video %s: %s", video_id, exc.detail)
            self._mark(video_id, error=exc.detail)
            return []
        frames = []
        for frame in result.frames:
            sha, _ = self.assets.store.put(frame.jpeg)
            verdict = msgspec.structs.replace(frame.verdict, file=f"{video.filename}@{frame.time_s:.3f}s.jpg")
            metadata = CaptureMetadata(captured_at=video.metadata.captured_at, width=frame.verdict.figures.width,
                                       height=frame.verdict.figures.height)  # fmt: skip
            frames.append(self.assets.add_derived(
                GATEWAY, video, AssetKind.frame, MediaType.jpeg, sha, len(frame.jpeg),
                f"{video.filename}@{frame.time_s:.3f}s.jpg", metadata, verdict,
            ))  # fmt: skip
        self._mark(video_id)
        log.info(
            "video %s: %d frames kept of %d decoded in %.2f s", video_id, len(frames), result.decoded, result.seconds
        )
        return frames

    def _mark(self, video_id: str, error: str | None = None) -> None:
        with self.db.write() as conn:
            conn.execute("UPDATE assets SET frames_done_at = ?, frames_error = ? WHERE id = ?",
                         (iso(utcnow()), error, video_id))  # fmt: skip
