"""Periodic work of the gateway, driven by APScheduler: for now, dropping expired uploads."""

from __future__ import annotations

import logging

from apscheduler.schedulers.background import BackgroundScheduler

from gateway.dependencies import Services

log = logging.getLogger("burnedge.scheduler")
EXPIRE_EVERY_S = 600


def start_scheduler(services: Services) -> BackgroundScheduler:
    scheduler = BackgroundScheduler(daemon=True)

    def expire_uploads() -> None:
        dropped = services.uploads.expire()
        if dropped:
            log.info("dropped %d expired unfinished uploads", dropped)

    expire_uploads()
    scheduler.add_job(expire_uploads, "interval", seconds=EXPIRE_EVERY_S, id="expire-uploads", coalesce=True)
    scheduler.start()
    return scheduler
