"""Runs the app under uvicorn, the ASGI server: plain HTTP, and HTTPS with the gateway's own certificate when phones
reach it on the clinic's network ([gateway] https, gateway/tls.py). Both listeners serve the one app, whose start
and stop (scheduler, analysis workers, database) run once around them."""

from __future__ import annotations

import asyncio
import contextlib
import logging
import signal

import uvicorn
from litestar import Litestar

from base.folders import keys_dir
from gateway import tls
from gateway.app import create_app
from schemas.config import Config

log = logging.getLogger("burnedge.gateway")
SHUTDOWN_GRACE_S = 5
"""On stop, open connections get this long to finish: a phone following progress (server-sent events) never
closes its stream by itself, and must not hold the gateway up."""
RENEW_CHECK_S = 24 * 3600


def serve(config: Config) -> None:
    app = create_app(config, start_workers=True)
    gateway = config.gateway
    if not tls.https_wanted(gateway):
        log.info(
            "gateway on http://%s:%d (database %s); API docs at /schema", gateway.host, gateway.port, gateway.database
        )
        uvicorn.run(app, **_common(gateway.host, gateway.port))
        return
    certificate = tls.server_certificate(keys_dir(config), config.report.clinic_name, gateway.tls_names)
    log.info(
        "gateway on https://%s:%d (certificate for %s, until %s) and http://%s:%d; phones: /phone-setup",
        gateway.host,
        gateway.https_port,
        ", ".join(certificate.names + certificate.addresses),
        certificate.not_after.date(),
        gateway.host,
        gateway.port,
    )
    asyncio.run(_serve_both(app, config, certificate))


def _common(host: str, port: int) -> dict:
    return {
        "host": host,
        "port": port,
        "log_level": "warning",
        "access_log": False,
        "timeout_graceful_shutdown": SHUTDOWN_GRACE_S,
    }


class _Listener(uvicorn.Server):
    """One of several listeners: the signals are handled once, for all of them (see _serve_both)."""

    @contextlib.contextmanager
    def capture_signals(self):
        yield


async def _serve_both(app: Litestar, config: Config, certificate: tls.ServerCertificate) -> None:
    gateway = config.gateway
    plain = _Listener(uvicorn.Config(app, lifespan="off", **_common(gateway.host, gateway.port)))
    secure = _Listener(
        uvicorn.Config(
            app,
            lifespan="off",
            ssl_certfile=str(certificate.cert),
            ssl_keyfile=str(certificate.key),
            **_common(gateway.host, gateway.https_port),
        )
    )
    listeners = [plain, secure]
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, lambda: [setattr(s, "should_exit", True) for s in listeners])
    async with app.lifespan():
        renewing = asyncio.create_task(_renew(config, secure))
        try:
            await asyncio.gather(*(s.serve() for s in listeners))
        finally:
            renewing.cancel()


async def _renew(config: Config, secure: _Listener) -> None:
    """Daily: a new server certificate when it nears expiry or the addresses changed, loaded for new connections."""
    while True:
        await asyncio.sleep(RENEW_CHECK_S)
        try:
            before = tls.server_certificate(keys_dir(config), config.report.clinic_name, config.gateway.tls_names)
            if secure.config.ssl is not None:
                secure.config.ssl.load_cert_chain(str(before.cert), str(before.key))
        except (OSError, ValueError) as exc:
            log.warning("could not renew the gateway's certificate: %s (the current one stays)", exc)
