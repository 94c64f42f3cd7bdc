"""A wound's healing track: every encounter's latest measured analysis of that wound, aligned with the first.

Each wound has its own track (WORK/patients/<patient>/wounds/<wound>/track.json); analyses made for a patient with
no wound recorded share the patient's own (WORK/patients/<patient>/track.json), as every analysis did before wounds
were kept. Recomputed by the worker after each analysis of the wound finishes (registrations already made are cached
on disk, so only the new visit is registered); the API serves the stored track.json.
"""

from __future__ import annotations

import datetime as dt
import logging
import sqlite3
from pathlib import Path

import msgspec

from base.storage import records as store
from gateway.jobs import folders
from gateway.storage import jobs
from gateway.storage.database import Database
from schemas.config import Config
from schemas.longitudinal import TrackResult
from schemas.records import RecordKind

log = logging.getLogger("burnedge.jobs")
TRACK = "track.json"


def sessions(db: Database, config: Config, patient_id: str, wound_id: str | None) -> list:
    """The latest finished measurement of the wound in each of the patient's encounters, with its day since the
    injury counted to when its pictures were taken (as the analysis counts its hours since injury)."""
    conn = db.connection()
    # A re-analysis of a visit replaces the earlier one.
    latest = {job.encounter_id: job for job in jobs.measured(conn, patient_id) if job.wound_id == wound_id}
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


def update_track(db: Database, config: Config, patient_id: str, wound_id: str | None) -> Path | None:
    """Recompute the wound's track (the patient's own for analyses of no wound); None with no measured visit."""
    visits = sessions(db, config, patient_id, wound_id)
    if not visits:
        return None
    from processing.longitudinal.track import run as track

    out = track_dir(config, patient_id, wound_id)
    path = track(config.tracking, visits, out)
    log.info("healing track of patient %s, wound %s: %d visits", patient_id, wound_id or "(none)", len(visits))
    return path


def track_dir(config: Config, patient_id: str, wound_id: str | None) -> Path:
    base = folders.patient_dir(config, patient_id)
    return base if wound_id is None else base / "wounds" / wound_id


def track_path(conn: sqlite3.Connection, config: Config, patient_id: str, wound_id: str | None) -> Path | None:
    """The wound's stored track.json; None when it has none yet. A wound the upgrade made has the patient's track
    of before until its next analysis, when every visit in it is one of the wound's."""
    path = track_dir(config, patient_id, wound_id) / TRACK
    if path.exists():
        return path
    legacy = folders.patient_dir(config, patient_id) / TRACK
    if wound_id is None or not legacy.exists():
        return None
    track = msgspec.json.decode(legacy.read_bytes(), type=TrackResult)
    ours = {job.id for job in jobs.measured(conn, patient_id) if job.wound_id == wound_id}
    visits = {job_of(s.analysis) for s in track.sessions}
    return legacy if visits and visits <= ours else None


def job_of(analysis_folder: str) -> str:
    """work_dir/<job id>/analysis -> <job id>."""
    return Path(analysis_folder).parent.name


def read_track(conn: sqlite3.Connection, config: Config, patient_id: str, wound_id: str | None) -> TrackResult | None:
    """The stored track as the API serves it (each visit's analysis as its API link, not the gateway's folder);
    None when the wound has no measured visit yet."""
    path = track_path(conn, config, patient_id, wound_id)
    if path is None:
        return None
    track = msgspec.json.decode(path.read_bytes(), type=TrackResult)
    linked = [msgspec.structs.replace(s, analysis=_link(s.analysis)) for s in track.sessions]
    return msgspec.structs.replace(track, sessions=linked)


def _link(folder: str) -> str:
    """work_dir/<job id>/analysis -> /api/v1/analyses/<job id>."""
    path = Path(folder)
    return f"/api/v1/analyses/{path.parent.name}" if path.name == "analysis" else ""
