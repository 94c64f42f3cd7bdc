"""Periodic work of the gateway, driven by APScheduler: expired uploads, frames from new videos."""

from __future__ import annotations

import logging

from apscheduler.schedulers.background import BackgroundScheduler

from gateway.dependencies import Services
from schemas.base import utcnow

log = logging.getLogger("burnedge.scheduler")
EXPIRE_EVERY_S = 600
FRAMES_EVERY_S = 60
FRAMES_JOB = "extract-frames"


def start_scheduler(services: Services) -> BackgroundScheduler:
    scheduler = BackgroundScheduler(daemon=True)

    def expire_uploads() -> None:
        dropped = services.uploads.expire()
        if dropped:
            log.info("dropped %d expired unfinished uploads", dropped)

    expire_uploads()
    scheduler.add_job(expire_uploads, "interval", seconds=EXPIRE_EVERY_S, id="expire-uploads", coalesce=True)
    # One job, one worker: extractions never run two at a time on the 2-core box.
    scheduler.add_job(services.frames.extract_pending, "interval", seconds=FRAMES_EVERY_S, id=FRAMES_JOB,
                      coalesce=True, max_instances=1, next_run_time=utcnow())  # fmt: skip
    scheduler.start()
    return scheduler


def run_frames_now(scheduler: BackgroundScheduler) -> None:
    """After a video upload: bring the frames job forward instead of waiting for its next turn."""
    scheduler.modify_job(FRAMES_JOB, next_run_time=utcnow())
