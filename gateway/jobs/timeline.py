"""A patient's healing track: every encounter's latest measured analysis, aligned with the first.

Recomputed by the worker after each analysis of the patient finishes (registrations already made are cached
on disk, so only the new visit is registered); the API serves the stored track.json.
"""

from __future__ import annotations

import datetime as dt
import logging
from pathlib import Path

import msgspec

from base.storage import records as store
from gateway.jobs import folders
from gateway.storage import jobs
from gateway.storage.database import Database
from schemas.config import Config
from schemas.errors import NotFound
from schemas.longitudinal import TrackResult
from schemas.records import RecordKind

log = logging.getLogger("burnedge.jobs")
TRACK = "track.json"


def sessions(db: Database, config: Config, patient_id: str) -> list:
    """The latest finished measurement of each of the patient's encounters, with its day since the injury counted
    to when its pictures were taken (as the analysis counts its hours since injury)."""
    conn = db.connection()
    # A re-analysis of a visit replaces the earlier one.
    latest = {job.encounter_id: job for job in jobs.measured(conn, patient_id)}
    visits = []
    for encounter_id, job in latest.items():
        encounter = store.find_head(conn, RecordKind.encounter, encounter_id)
        if encounter is None or encounter.meta.deleted:
            continue
        visit = encounter.value()
        # Jobs queued before capture times were kept: the visit's arrival stands in.
        taken = dt.datetime.fromisoformat(job.captured.at) if job.captured else visit.time_of_arrival
        visits.append((taken, job.id, visit.time_of_injury))
    visits.sort()
    from processing.longitudinal.track import SessionAnalysis  # Open3D: only ever in a job's process

    if not visits:
        return []
    # Days since the injury when the first visit recorded it (the day-21 healing prompt counts from the injury),
    # else since the first visit.
    start = visits[0][2] or visits[0][0]
    days = [round(max(0.0, (at - start).total_seconds()) / 86400, 2) for at, _, _ in visits]
    return [
        SessionAnalysis(day=day, label=f"day {day:.0f}", analysis_dir=folders.analysis_dir(config, job_id))
        for day, (_, job_id, _) in zip(days, visits, strict=True)
    ]


def update_track(db: Database, config: Config, patient_id: str) -> Path | None:
    """Recompute the patient's track; None when the patient has no measured visit yet."""
    visits = sessions(db, config, patient_id)
    if not visits:
        return None
    from processing.longitudinal.track import run as track

    out = folders.patient_dir(config, patient_id)
    path = track(config.tracking, visits, out)
    log.info("healing track of patient %s: %d visits", patient_id, len(visits))
    return path


def track_path(config: Config, patient_id: str) -> Path:
    return folders.patient_dir(config, patient_id) / TRACK


def read_track(config: Config, patient_id: str) -> TrackResult:
    """The stored track as the API serves it: each visit's analysis as its API link, not the gateway's folder."""
    path = track_path(config, patient_id)
    if not path.exists():
        raise NotFound(f"patient {patient_id} has no measured visit yet: the track starts with the first analysis")
    track = msgspec.json.decode(path.read_bytes(), type=TrackResult)
    linked = [msgspec.structs.replace(s, analysis=_link(s.analysis)) for s in track.sessions]
    return msgspec.structs.replace(track, sessions=linked)


def _link(folder: str) -> str:
    """work_dir/<job id>/analysis -> /api/v1/analyses/<job id>."""
    path = Path(folder)
    return f"/api/v1/analyses/{path.parent.name}" if path.name == "analysis" else ""
