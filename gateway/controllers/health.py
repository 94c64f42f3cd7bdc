"""Liveness and readiness: the only endpoint without authentication besides the ways in."""

from __future__ import annotations

from litestar import get

from gateway import __version__
from gateway.dependencies import ServicesDep
from schemas.accounts import Health


@get(
    "/health",
    sync_to_thread=False,
    exclude_from_auth=True,
    tags=["health"],
    summary="Is the gateway up and its database readable?",
)
def health(services: ServicesDep) -> Health:
    services.db.connection().execute("SELECT 1 FROM _sqlite_migrations LIMIT 1").fetchall()
    return Health(status="ok", version=__version__)
