"""Periodic work of the gateway, driven by APScheduler."""

from __future__ import annotations

import logging

from apscheduler.schedulers.background import BackgroundScheduler

from gateway.dependencies import Services
from gateway.jobs.folders import clean_up
from gateway.jobs.supervisor import Workers
from schemas.base import utcnow

log = logging.getLogger("burnedge.scheduler")
FRAMES_JOB = "extract-frames"
SYNC_JOB = "sync-with-center"


def start_scheduler(services: Services, workers: Workers | None = None) -> BackgroundScheduler:
    """Upload housekeeping, frames from videos, requeueing jobs of dead workers, restarting those workers, and
    the analyses' retention clean-up; each job never runs twice at once."""
    scheduler = BackgroundScheduler(daemon=True)
    config = services.config

    def upload_housekeeping() -> None:
        completed, dropped = services.uploads.housekeeping()
        if completed or dropped:
            log.info("uploads: completed %d left unrecorded by a restart, dropped %d expired", completed, dropped)

    # One job each, never two runs at once: extraction especially is heavy on the 2-core box.
    scheduler.add_job(
        upload_housekeeping,
        "interval",
        seconds=config.uploads.housekeeping_every_s,
        id="upload-housekeeping",
        coalesce=True,
        max_instances=1,
        next_run_time=utcnow(),
    )
    scheduler.add_job(
        services.frames.extract_pending,
        "interval",
        seconds=config.frames.poll_every_s,
        id=FRAMES_JOB,
        coalesce=True,
        max_instances=1,
        next_run_time=utcnow(),
    )
    scheduler.add_job(
        services.analyses.queue.reap,
        "interval",
        seconds=config.jobs.reap_every_s,
        id="requeue-lost-jobs",
        coalesce=True,
        max_instances=1,
        next_run_time=utcnow(),
    )
    if workers is not None:
        scheduler.add_job(
            workers.check,
            "interval",
            seconds=config.jobs.reap_every_s,
            id="restart-dead-workers",
            coalesce=True,
            max_instances=1,
        )
    scheduler.add_job(
        lambda: clean_up(services.db, config),
        "interval",
        seconds=config.jobs.cleanup_every_s,
        id="analysis-retention",
        coalesce=True,
        max_instances=1,
        next_run_time=utcnow(),
    )
    # Always scheduled: the round itself checks the link, which the Burn center page may enable at any time.
    sync = services.transfers.sync
    scheduler.add_job(
        sync.scheduled_round,
        "interval",
        seconds=config.sync.interval_s,
        id=SYNC_JOB,
        coalesce=True,
        max_instances=1,
        next_run_time=utcnow(),
    )
    # A clinician sending a case: one round now, whatever the backoff (the round lock keeps it single).
    services.run_sync_now = lambda: scheduler.add_job(
        sync.scheduled_round, kwargs={"force": True}, id=SYNC_JOB + "-now", replace_existing=True
    )
    scheduler.start()
    return scheduler


def run_frames_now(scheduler: BackgroundScheduler) -> None:
    """After a video upload: bring the frames job forward instead of waiting for its next turn."""
    scheduler.modify_job(FRAMES_JOB, next_run_time=utcnow())
