"""Runs the app under uvicorn, the ASGI server."""

from __future__ import annotations

import logging

import uvicorn

from gateway.app import create_app
from schemas.config import Config

log = logging.getLogger("burnedge.gateway")


def serve(config: Config) -> None:
    app = create_app(config)
    log.info("gateway on http://%s:%d (database %s); API docs at /schema",
             config.gateway.host, config.gateway.port, config.gateway.database)  # fmt: skip
    uvicorn.run(app, host=config.gateway.host, port=config.gateway.port, log_level="warning", access_log=False)
