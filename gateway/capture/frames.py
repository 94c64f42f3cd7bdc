"""Frames from uploaded videos, stored as assets linked to their video.

A video asset is done once its frames are stored (frames_done_at). Pending videos are
picked up after each video upload and by the scheduler, so a gateway restarted in the
middle of an extraction finishes it later. The frames of one video are stored together:
their JPEG files first, then their asset rows and the video's frames_done_at in one
transaction, so a crash leaves either all of them or none (and at most unreferenced files).
One video failing does not stop the others; a video the extractor fails on is tried at
most twice, then marked done with frames_error.
"""

from __future__ import annotations

import logging
import sqlite3

import msgspec

from base.accounts.permissions import Principal
from base.storage import assets as asset_rows
from gateway.capture.assets import AssetService, insert_asset_row
from gateway.records.validation import require_live_encounter
from gateway.storage.database import Database
from processing.capture.frames import ExtractedFrame, extract
from schemas.accounts import Role
from schemas.capture import Asset, AssetKind, CaptureMetadata, MediaType
from schemas.config import Config
from schemas.errors import BurnedgeError, InvalidInput, NotFound

log = logging.getLogger("burnedge.frames")
GATEWAY = Principal(user_id="gateway", username="gateway", role=Role.clinician, device_id=None, session_hash="")
"""The gateway itself, as the author of the frames it extracts."""


class FrameService:
    def __init__(self, db: Database, config: Config, assets: AssetService):
        self.db, self.config, self.assets = db, config, assets

    def pending(self) -> list[str]:
        """Ids of the videos whose frames are not stored yet, oldest first."""
        return asset_rows.pending_video_ids(self.db.connection())

    def extract_pending(self) -> int:
        """Extract and store the frames of every pending video; returns how many were processed.

        A video that cannot be stored (disk full, database busy) is logged and left pending for
        the next run; the videos after it are still processed.
        """
        done = 0
        for video_id in self.pending():
            try:
                self.extract_one(video_id)
            except Exception:
                log.exception("frames of video %s not stored, to be retried", video_id)
                continue
            done += 1
        return done

    def extract_one(self, video_id: str) -> list[Asset]:
        """Extract a video's frames and store them; returns the frame assets ([] if another run stored them).

        A video that does not decode is marked done with frames_error at once. Any other failure
        of the extractor (a bug it hits on these bytes) is recorded in frames_error and the video
        tried once more at the next run, in case the failure was the gateway stopping; a second
        failure marks it done.
        """
        video = self.assets.get(GATEWAY, video_id)
        path = self.assets.store.blob(video.sha256)
        try:
            result = extract(path, self.config.frames, self.config.quality, name=video.filename)
        except BurnedgeError as exc:
            log.warning("no frames from video %s: %s", video_id, exc.detail)
            self._mark(video_id, error=exc.detail)
            return []
        except Exception as exc:
            log.exception("frame extraction failed on video %s", video_id)
            self._failed(video_id, f"frame extraction failed ({type(exc).__name__}: {exc})"[:500])
            return []
        # The files first: a committed row never names a missing file.
        stored = [(self.assets.store.put(frame.jpeg)[0], frame) for frame in result.frames]
        ids = self._store(video, stored)
        if ids is None:
            log.info("video %s: frames already stored by another run", video_id)
            return []
        log.info("video %s: %d frames kept of %d decoded in %.2f s", video_id, len(ids), result.decoded, result.seconds)
        return [self.assets.get(GATEWAY, i) for i in ids]

    def _store(self, video: Asset, frames: list[tuple[str, ExtractedFrame]]) -> list[str] | None:
        """All frame rows, their audit entries and the video's frames_done_at, in one transaction.

        None if the video was done meanwhile. Frames whose bytes the encounter already has keep that asset.
        """
        with self.db.write() as conn:
            progress = asset_rows.find_frames_progress(conn, video.id)
            if progress is None or progress.done_at is not None:
                return None
            try:
                require_live_encounter(conn, video.encounter_id)
            except (InvalidInput, NotFound) as exc:
                asset_rows.set_frames_done(conn, video.id, exc.detail)
                return []
            ids = [_insert_frame(conn, video, sha, frame) for sha, frame in frames]
            asset_rows.set_frames_done(conn, video.id, None)
        return list(dict.fromkeys(ids))

    def _mark(self, video_id: str, error: str | None = None) -> None:
        with self.db.write() as conn:
            asset_rows.set_frames_done(conn, video_id, error)

    def _failed(self, video_id: str, error: str) -> None:
        with self.db.write() as conn:
            progress = asset_rows.find_frames_progress(conn, video_id)
            if progress is None or progress.done_at is not None:
                return
            if progress.error is None:
                asset_rows.set_frames_error(conn, video_id, error)
            else:
                asset_rows.set_frames_done(conn, video_id, error)


def _insert_frame(conn: sqlite3.Connection, video: Asset, sha: str, frame: ExtractedFrame) -> str:
    """One frame's asset row and audit entry, linked to its video; returns its id."""
    name = f"{video.filename}@{frame.time_s:.3f}s.jpg"
    verdict = msgspec.structs.replace(frame.verdict, file=name)
    metadata = CaptureMetadata(
        captured_at=video.metadata.captured_at, width=frame.verdict.figures.width, height=frame.verdict.figures.height
    )
    return insert_asset_row(
        conn,
        GATEWAY,
        video.encounter_id,
        AssetKind.frame,
        MediaType.jpeg,
        sha,
        len(frame.jpeg),
        name,
        metadata,
        verdict,
        video.id,
        wound_id=video.wound_id,
    )
