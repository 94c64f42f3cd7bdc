"""Runs the app under uvicorn, the ASGI server."""

from __future__ import annotations

import logging

import uvicorn

from gateway.app import create_app
from schemas.config import Config

log = logging.getLogger("burnedge.gateway")
SHUTDOWN_GRACE_S = 5
"""On stop, open connections get this long to finish: a phone following progress (server-sent events) never
closes its stream by itself, and must not hold the gateway up."""


def serve(config: Config) -> None:
    app = create_app(config, start_workers=True)
    log.info(
        "gateway on http://%s:%d (database %s); API docs at /schema",
        config.gateway.host,
        config.gateway.port,
        config.gateway.database,
    )
    uvicorn.run(
        app,
        host=config.gateway.host,
        port=config.gateway.port,
        log_level="warning",
        access_log=False,
        timeout_graceful_shutdown=SHUTDOWN_GRACE_S,
    )
