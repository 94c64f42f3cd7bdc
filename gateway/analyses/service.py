"""Analyses requested over the API: checking a request, queueing it once, and reading back what it gave."""

from __future__ import annotations

import base64
import binascii
import hashlib
import json
from pathlib import Path

import cv2
import msgspec
import numpy as np

from base.accounts.permissions import Principal, require_capture, require_read
from base.storage import assets as asset_rows
from base.storage import audit
from base.storage import records as store
from gateway.capture.assets import AssetService
from gateway.jobs import folders
from gateway.jobs.capture_time import capture_time
from gateway.jobs.estimate import HISTORY, StageTimes, stage_times
from gateway.jobs.queue import JobQueue
from gateway.records.validation import require_live_encounter
from gateway.storage.database import Database
from gateway.wounds.choice import wound_of_analysis
from processing.stages import code_digest
from schemas.analysis import AnalysisResult
from schemas.capture import Asset, AssetKind, MediaType
from schemas.config import Config
from schemas.errors import Conflict, InvalidInput
from schemas.jobs import AnalysisJob, AnalysisRequest, BurnAnalysis, JobAttempt, JobInputs, JobState, PictureRef
from schemas.records import RecordKind

SUFFIX = {MediaType.jpeg: ".jpg", MediaType.png: ".png", MediaType.heic: ".heic"}


class AnalysisService:
    def __init__(self, db: Database, config: Config, assets: AssetService):
        self.db, self.config, self.assets = db, config, assets
        self.queue = JobQueue(db, config.jobs)

    def request(self, principal: Principal, encounter_id: str, body: AnalysisRequest) -> tuple[AnalysisJob, bool]:
        """Queue an analysis of the encounter's pictures; the same request again returns the same job.

        Returns the job and whether it was created now.
        """
        require_capture(principal)
        with self.db.read() as conn:
            encounter = require_live_encounter(conn, encounter_id)
            wound = wound_of_analysis(conn, encounter.value().patient_id, body.wound_id)
        wound_id = wound.meta.id if wound is not None else None
        pictures = self._pictures(principal, encounter_id, body, wound_id)
        by_id = {p.id: p for p in pictures}
        for mask in body.masks:
            _check_mask(mask, by_id)
        if body.ruler is not None:
            for mark in body.ruler.marks:
                if mark.asset_id not in by_id:
                    raise InvalidInput(f"ruler mark on {mark.asset_id}, which is not one of the analysed pictures")
        refs = [
            PictureRef(asset_id=p.id, sha256=p.sha256, suffix=SUFFIX[p.media_type], filename=p.filename)
            for p in pictures
        ]
        visit = encounter.value()
        with self.db.read() as conn:
            patient = store.get_head(conn, RecordKind.patient, visit.patient_id).data
        # What the analysis reads from the record (%TBSA, provisional): a correction makes a new analysis. The
        # stored JSON values are hashed as they are, so a job queued before keeps its digest.
        record = [
            patient.get("height_cm"),
            patient.get("weight_kg"),
            encounter.data.get("weight_kg"),
            encounter.data.get("time_of_injury"),
        ]
        digest = _digest(self.config, refs, body, record, wound_id)
        captured = capture_time(pictures, visit.time_of_injury, self.config.analysis)
        # The queue stamps requested_at when it queues the job.
        inputs = JobInputs(
            pictures=refs, masks=body.masks, ruler=body.ruler, marker_side_mm=body.marker_side_mm, captured=captured
        )
        with self.db.write() as conn:
            require_live_encounter(conn, encounter_id)
            job_id, created = self.queue.enqueue_in(
                conn,
                encounter_id=encounter_id,
                patient_id=visit.patient_id,
                input_digest=digest,
                inputs=inputs,
                mode=visit.mode,
                created_by=principal.username,
                user_id=principal.user_id,
                wound_id=wound_id,
            )
            if created:
                audit.append(
                    conn,
                    action="analysis.request",
                    user_id=principal.user_id,
                    device_id=principal.device_id,
                    kind="analysis_job",
                    record_id=job_id,
                    detail=json.dumps({"encounter": encounter_id, "wound": wound_id, "pictures": len(refs)}),
                )
        return self.queue.get(job_id), created

    def _pictures(
        self, principal: Principal, encounter_id: str, body: AnalysisRequest, wound_id: str | None
    ) -> list[Asset]:
        stored = self.assets.for_encounter(principal, encounter_id)
        aside = [a.filename for a in stored if a.set_aside is not None and body.assets and a.id in body.assets]
        if aside:
            raise InvalidInput(f"{', '.join(aside)} set aside: leave them out, or put them back first")
        stored = [a for a in stored if a.set_aside is None]
        if body.assets is None and wound_id is not None:
            stored = _of_wound(stored, wound_id)
        pending = [a.filename for a in stored if a.kind is AssetKind.video and not _frames_done(self.db, a.id)]
        if body.assets is None:
            if pending:
                raise Conflict(f"frames are still being taken from {', '.join(pending)}: ask again in a minute")
            chosen = [a for a in stored if a.kind in (AssetKind.photo, AssetKind.frame)]
        else:
            by_id = {a.id: a for a in stored}
            missing = [i for i in body.assets if i not in by_id]
            if missing:
                raise InvalidInput(f"not pictures of this encounter: {', '.join(missing)}")
            chosen = [by_id[i] for i in dict.fromkeys(body.assets)]
            videos = [a.filename for a in chosen if a.kind is AssetKind.video]
            if videos:
                raise InvalidInput(f"{', '.join(videos)}: give the frames taken from a video, not the video")
            elsewhere = [a.filename for a in chosen if wound_id is not None and a.wound_id not in (None, wound_id)]
            if elsewhere:
                raise InvalidInput(
                    f"{', '.join(elsewhere)} show another wound: leave them out, or move them to this wound first"
                    " (PUT /api/v1/assets/{id}/wound)"
                )
        minimum = self.config.reconstruction.min_views
        if not chosen and wound_id is not None:
            raise InvalidInput(
                "no picture of this wound in the encounter: upload its pictures with the wound named"
                " (Upload-Metadata wound_id) or set the wound of pictures already sent"
            )
        if len(chosen) < minimum:
            raise InvalidInput(
                f"{len(chosen)} pictures: a 3D analysis needs at least {minimum} (the capture "
                "readiness check says what is missing)"
            )
        return chosen

    def get(self, principal: Principal, job_id: str) -> AnalysisJob:
        require_read(principal, RecordKind.burn_analysis)
        return self.queue.get(job_id)

    def stage_times(self, principal: Principal) -> StageTimes:
        """Each stage's median time over this gateway's latest finished analyses (gateway/jobs/estimate.py)."""
        require_read(principal, RecordKind.burn_analysis)
        with self.db.read() as conn:
            latest = store.newest_heads(conn, RecordKind.burn_analysis, HISTORY)
        results = [msgspec.convert(r.data, BurnAnalysis).result for r in latest]
        return stage_times([(r.timings_s, r.reused_stages) for r in results])

    def attempts(self, principal: Principal, job_id: str) -> list[JobAttempt]:
        """Every try of the job and how it ended; the logs' server paths are shortened."""
        require_read(principal, RecordKind.burn_analysis)
        return [
            msgspec.structs.replace(a, log_tail=folders.without_server_paths(self.config, a.log_tail))
            for a in self.queue.attempt_history(job_id)
        ]

    def for_encounter(self, principal: Principal, encounter_id: str) -> list[AnalysisJob]:
        require_read(principal, RecordKind.burn_analysis)
        store.get_head(self.db.connection(), RecordKind.encounter, encounter_id)
        return self.queue.for_encounter(encounter_id)

    def cancel(self, principal: Principal, job_id: str) -> AnalysisJob:
        require_capture(principal)
        state = self.queue.cancel(job_id)
        with self.db.write() as conn:
            audit.append(
                conn,
                action="analysis.cancel",
                user_id=principal.user_id,
                device_id=principal.device_id,
                kind="analysis_job",
                record_id=job_id,
                detail=state.value,
            )
        return self.queue.get(job_id)

    def result(self, principal: Principal, job_id: str) -> AnalysisResult:
        """The measurement (from the patient's record), or the reason a finished analysis gave none."""
        job = self.get(principal, job_id)
        record = store.find_head(self.db.connection(), RecordKind.burn_analysis, job_id)
        if record is not None:
            return msgspec.convert(record.data, BurnAnalysis).result
        path = folders.analysis_dir(self.config, job_id) / "analysis.json"
        if job.state is JobState.failed and path.exists():
            return msgspec.json.decode(path.read_bytes(), type=AnalysisResult)
        if job.state is JobState.failed:
            raise Conflict(f"the analysis failed without a result: {job.error}")
        raise Conflict(f"the analysis is {job.state.value} ({job.message}); its result is not there yet")

    def artifacts(self, principal: Principal, job_id: str) -> list[str]:
        self.get(principal, job_id)
        return folders.artifacts(self.config, job_id)

    def artifact(self, principal: Principal, job_id: str, name: str) -> Path:
        self.get(principal, job_id)
        return folders.artifact_file(self.config, job_id, name)


def _of_wound(stored: list[Asset], wound_id: str) -> list[Asset]:
    """The wound's pictures; when none is marked with any wound (one wound, pictures sent before it was recorded or
    without saying), every picture of the encounter."""
    if all(a.wound_id is None for a in stored):
        return stored
    return [a for a in stored if a.wound_id == wound_id]


def _frames_done(db: Database, video_id: str) -> bool:
    progress = asset_rows.find_frames_progress(db.connection(), video_id)
    return progress is not None and progress.done_at is not None


def _check_mask(mask, pictures: dict[str, Asset]) -> None:
    asset = pictures.get(mask.asset_id)
    if asset is None:
        raise InvalidInput(f"mask for {mask.asset_id}, which is not one of the analysed pictures")
    if (mask.png_base64 is None) == (mask.polygons is None):
        raise InvalidInput(f"mask for {mask.asset_id}: give either png_base64 or polygons")
    if mask.png_base64 is None:
        return
    try:
        data = base64.b64decode(mask.png_base64, validate=True)
    except (ValueError, binascii.Error) as exc:
        raise InvalidInput(f"mask for {mask.asset_id}: png_base64 is not base64") from exc
    image = (
        cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_GRAYSCALE) if data[:8] == b"\x89PNG\r\n\x1a\n" else None
    )
    if image is None:
        raise InvalidInput(f"mask for {mask.asset_id}: not a PNG image")
    size = (
        (asset.verdict.figures.width, asset.verdict.figures.height) if asset.verdict and asset.verdict.figures else None
    )
    if size is not None and (image.shape[1], image.shape[0]) != size:
        raise InvalidInput(
            f"mask for {mask.asset_id} is {image.shape[1]}x{image.shape[0]} but the picture is "
            f"{size[0]}x{size[1]}: draw it on the picture as stored"
        )


def _digest(config: Config, refs: list[PictureRef], body: AnalysisRequest, record: list, wound_id: str | None) -> str:
    """What makes two requests the same analysis: the pictures' bytes, masks, ruler, the record's figures it
    uses, the wound, settings and code. (No wound adds nothing, so a request of before wounds keeps its digest.)"""
    settings = [
        msgspec.to_builtins(config.quality),
        msgspec.to_builtins(config.reconstruction),
        msgspec.to_builtins(msgspec.structs.replace(config.analysis, threads=1)),
    ]
    parts = [
        sorted(r.sha256 for r in refs),
        msgspec.to_builtins(body.masks),
        msgspec.to_builtins(body.ruler),
        body.marker_side_mm,
        record,
        settings,
        code_digest(),
    ]
    if wound_id is not None:
        parts.append(wound_id)
    return hashlib.sha256(json.dumps(parts, sort_keys=True).encode()).hexdigest()
