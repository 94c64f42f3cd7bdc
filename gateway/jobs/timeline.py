"""A patient's healing track: every encounter's latest measured analysis, aligned with the first.

Recomputed by the worker after each analysis of the patient finishes (registrations already made are cached
on disk, so only the new visit is registered); the API serves the stored track.json.
"""

from __future__ import annotations

import datetime as dt
import logging
from pathlib import Path

import msgspec

from gateway.jobs import folders
from gateway.storage import records as store
from gateway.storage.database import Database
from schemas.config import Config
from schemas.errors import NotFound
from schemas.longitudinal import TrackResult
from schemas.records import RecordKind

log = logging.getLogger("burnedge.jobs")
TRACK = "track.json"


def sessions(db: Database, config: Config, patient_id: str) -> list:
    """The latest finished measurement of each of the patient's encounters, with its day since the injury."""
    conn = db.connection()
    rows = conn.execute(
        "SELECT id, encounter_id FROM analysis_jobs WHERE patient_id = ? AND state = 'done'"
        " AND result_status = 'ok' ORDER BY finished_at",
        (patient_id,),
    ).fetchall()
    latest = {r["encounter_id"]: r["id"] for r in rows}  # a re-analysis of a visit replaces the earlier one
    visits = []
    for encounter_id, job_id in latest.items():
        encounter = store.find_head(conn, RecordKind.encounter, encounter_id)
        if encounter is None or encounter.meta.deleted:
            continue
        injury = encounter.data.get("time_of_injury")
        visits.append((dt.datetime.fromisoformat(encounter.data["time_of_arrival"]), encounter_id, job_id,
                       dt.datetime.fromisoformat(injury) if injury else None))  # fmt: skip
    visits.sort()
    from processing.longitudinal.track import SessionAnalysis  # Open3D: only ever in a job's process

    if not visits:
        return []
    # Days since the injury when the first visit recorded it (the day-21 healing prompt counts from the injury),
    # else since the first visit.
    start = visits[0][3] or visits[0][0]
    return [
        SessionAnalysis(
            day=round((at - start).total_seconds() / 86400, 2),
            label=f"encounter {encounter_id}",
            analysis_dir=folders.analysis_dir(config, job_id),
        )  # fmt: skip
        for at, encounter_id, job_id, _ in visits
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


def read_track(config: Config, patient_id: str) -> TrackResult:
    path = folders.patient_dir(config, patient_id) / TRACK
    if not path.exists():
        raise NotFound(f"patient {patient_id} has no measured visit yet: the track starts with the first analysis")
    return msgspec.json.decode(path.read_bytes(), type=TrackResult)
