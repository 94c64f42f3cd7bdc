"""One try of one analysis job, run in a process of its own that its worker may kill (cancel, lost lease).

It lays out the job's inputs (idempotently: a retry finds them there), runs or resumes the analysis with
progress reported to the queue, and stores the outcome: the job's final state and, for a measurement, the
`burn_analysis` record in the patient's record, in one transaction that only commits while the job is still
this try's. The patient's healing track is then brought up to date.
"""

from __future__ import annotations

import base64
import datetime as dt
import logging
import os
import shutil
import signal
import time
import traceback
from collections.abc import Sequence
from pathlib import Path

import msgspec

from base.folders import media_root
from base.storage import audit
from base.storage import records as store
from base.storage.blobs import MediaStore
from gateway.jobs import folders
from gateway.jobs.capture_time import hours_since_injury
from gateway.jobs.estimate import STAGES
from gateway.jobs.events import AnalysisStored, Reaction, publish
from gateway.jobs.queue import Claim, JobQueue
from gateway.storage import jobs
from gateway.storage.database import Database
from processing.analysis.pipeline import Patient
from processing.analysis.pipeline import run as analyze
from processing.stages import write_json
from schemas.analysis import AnalysisResult, AnalysisStatus
from schemas.base import iso, utcnow
from schemas.config import Config
from schemas.errors import BurnedgeError, StorageError
from schemas.jobs import BurnAnalysis, JobInputs, JobState, StoredJob
from schemas.reconstruction import RulerMark, RulerPoints
from schemas.records import RecordKind

log = logging.getLogger("burnedge.jobs")


def run(config: Config, claim: Claim, reactions: Sequence[Reaction] = ()) -> JobState:
    """Run one try of the job; returns the state it was left in. Once stored, the analysis is published to
    `reactions` (gateway/jobs/events.py)."""
    db = Database.from_config(config.gateway)
    queue = JobQueue(db, config.jobs)
    try:
        job = jobs.get(db.connection(), claim.job_id)
        inputs = jobs.inputs(db.connection(), claim.job_id)
        folder = folders.job_dir(config, claim.job_id)
        source, masks, ruler = _lay_out(config, folder, inputs)
        patient = _patient(db, job.encounter_id, inputs)
        if inputs.marker_side_mm is not None:
            config = msgspec.structs.replace(
                config,
                reconstruction=msgspec.structs.replace(config.reconstruction, marker_side_mm=inputs.marker_side_mm),
            )

        def progress(stage: str) -> None:
            start, text = STAGES.get(stage, (0.0, stage))
            try:
                queue.progress(claim, stage, start, text)
            except StorageError:  # progress is for people waiting; the analysis goes on without it
                log.warning("analysis %s: progress not recorded (database busy)", claim.job_id)

        result = analyze(
            config, source, folder / "analysis", masks=masks, ruler=ruler, patient=patient, progress=progress
        )
        state = _store(db, queue, claim, job, inputs, result)
        if state is JobState.done:
            event = AnalysisStored(
                job_id=claim.job_id, encounter_id=job.encounter_id, patient_id=job.patient_id, wound_id=job.wound_id
            )
            publish(reactions, db, config, event)
        return state
    finally:
        db.close()


def _lay_out(config: Config, folder: Path, inputs: JobInputs) -> tuple[Path, Path | None, RulerPoints | None]:
    store = MediaStore(media_root(config))
    source = folder / "source"
    source.mkdir(parents=True, exist_ok=True)
    for picture in inputs.pictures:
        target = source / f"{picture.stem}{picture.suffix}"
        if not target.exists():
            tmp = target.with_name(target.name + ".tmp")
            tmp.unlink(missing_ok=True)
            try:
                os.link(store.blob(picture.sha256), tmp)  # the blob is never modified: a link is a free copy
            except OSError:  # work_dir on another file system
                shutil.copyfile(store.blob(picture.sha256), tmp)
            os.replace(tmp, target)
    pictures = {p.asset_id: p for p in inputs.pictures}
    masks = None
    if inputs.masks:
        masks = folder / "masks"
        masks.mkdir(exist_ok=True)
        for mask in inputs.masks:
            if mask.png_base64:
                (masks / f"{pictures[mask.asset_id].stem}.png").write_bytes(base64.b64decode(mask.png_base64))
            else:
                write_json(masks / f"{pictures[mask.asset_id].stem}.json", {"polygons": mask.polygons})
    ruler = None
    if inputs.ruler is not None:
        ruler = RulerPoints(
            distance_mm=inputs.ruler.distance_mm,
            marks=[
                RulerMark(image=f"{pictures[m.asset_id].stem}{pictures[m.asset_id].suffix}", a=m.a, b=m.b)
                for m in inputs.ruler.marks
            ],
        )
    return source, masks, ruler


def _patient(db: Database, encounter_id: str, inputs: JobInputs) -> Patient:
    """What the analysis may know: hours since injury (to when the pictures were taken), height and weight for
    %TBSA."""
    conn = db.connection()
    encounter = store.get_head(conn, RecordKind.encounter, encounter_id).data
    patient = store.get_head(conn, RecordKind.patient, encounter["patient_id"]).data
    hours = None
    # Jobs an older gateway queued carry no capture time: their request's time stands in.
    taken = inputs.captured.at if inputs.captured else inputs.requested_at
    if encounter.get("time_of_injury") and taken:
        hours = hours_since_injury(taken, dt.datetime.fromisoformat(encounter["time_of_injury"]))
    weight = encounter.get("weight_kg") or patient.get("weight_kg")
    height = patient.get("height_cm")
    if weight is None or height is None:
        weight = height = None
    return Patient(hours_since_injury=hours, height_cm=height, weight_kg=weight)


def _store(
    db: Database, queue: JobQueue, claim: Claim, job: StoredJob, inputs: JobInputs, result: AnalysisResult
) -> JobState:
    now = iso(utcnow())
    with db.write() as conn:
        if result.status is AnalysisStatus.failed:
            kept = queue.finish_in(
                conn,
                claim,
                JobState.failed,
                result_status="failed",
                error=result.reason,
                message="no measurement: see the reason",
            )
            return JobState.failed if kept else JobState.running
        if not queue.finish_in(
            conn, claim, JobState.done, result_status=result.status.value, error=None, message="finished"
        ):
            return JobState.running
        record = BurnAnalysis(
            encounter_id=job.encounter_id,
            job_id=claim.job_id,
            assets=[p.asset_id for p in inputs.pictures],
            requested_by=job.created_by,
            requested_at=job.created_at,
            completed_at=now,
            captured=inputs.captured,
            result=result,
            wound_id=job.wound_id,
        )
        audit.insert_server_record(
            conn,
            kind=RecordKind.burn_analysis,
            record_id=claim.job_id,
            parent_id=job.encounter_id,
            data=msgspec.json.encode(record),
            action="analysis.store",
        )
    log.info("analysis %s stored: %s, area %s cm2", claim.job_id, result.status.value, result.metrics.area_cm2)
    return JobState.done


def child_main(config: Config, claim: Claim, reactions: Sequence[Reaction] = ()) -> None:
    """Entry point of the job's process: dies with its worker, records a crash of its own for a retry."""
    _die_with_parent()
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # its worker decides when it stops
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    started = time.perf_counter()
    try:
        state = run(config, claim, reactions)
    except BurnedgeError as exc:
        if isinstance(exc, StorageError):  # the database was busy: worth another try
            _retry(config, claim, f"stopped: the database was busy ({exc.detail})")
            raise SystemExit(1) from exc
        # Bad input or data: trying again would fail the same way.
        log.error("analysis %s: %s", claim.job_id, exc.detail)
        db = Database.from_config(config.gateway)
        try:
            JobQueue(db, config.jobs).finish(claim, JobState.failed, error=exc.detail, message="failed")
        finally:
            db.close()
        return
    except Exception as exc:
        log.exception("analysis %s stopped on an unexpected error", claim.job_id)
        _retry(
            config,
            claim,
            f"stopped on an unexpected error ({type(exc).__name__}: {str(exc)[:300]})",
            traceback.format_exc(),
        )
        raise SystemExit(1) from exc
    log.info("analysis %s: %s after %.1f s", claim.job_id, state.value, time.perf_counter() - started)


def _retry(config: Config, claim: Claim, reason: str, log_tail: str = "") -> None:
    db = Database.from_config(config.gateway)
    try:
        JobQueue(db, config.jobs).retry_or_fail(claim, reason, exit="exit code 1", log_tail=log_tail)
    except StorageError:
        log.warning("analysis %s: the retry is left to the lease running out (database busy)", claim.job_id)
    finally:
        db.close()


def _die_with_parent() -> None:
    """Linux: SIGKILL this process when its worker dies, so no orphan keeps writing into the job's folder."""
    import ctypes
    import multiprocessing

    try:
        libc = ctypes.CDLL("libc.so.6", use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except OSError:
        log.warning("cannot tie the analysis process to its worker (not Linux?)")
    parent = multiprocessing.parent_process()
    if parent is not None and os.getppid() != parent.pid:  # the worker died before prctl took effect
        os._exit(1)
