"""Liveness and readiness: without authentication, as are the ways in and what a phone needs before it captures
(gateway/capture/settings_controller.py); none of them holds patient data."""

from __future__ import annotations

from litestar import get

from base import __version__
from base.web.site import SiteServicesDep
from schemas.accounts import Health


@get(
    "/health",
    sync_to_thread=False,
    exclude_from_auth=True,
    tags=["health"],
    summary="Is the server up and its database readable?",
)
def health(services: SiteServicesDep) -> Health:
    services.db.check_readable()
    return Health(status="ok", version=__version__)
