"""`burnedge central router`: the center's Zenoh router on its own, for clinics and several center workers.

It holds no state and reads no database: clinics connect to it, workers connect to it (their `[central]
router_endpoints`), and Zenoh routes each clinic's requests to the worker that answers for that clinic
(center/workers.py). A standalone `zenohd` with the same endpoints does the same job.
"""

from __future__ import annotations

import logging
import signal
import threading

import zenoh

from schemas.config import CentralConfig
from sync.wire import LinkDown
from sync.zenoh_link import router_session_config

log = logging.getLogger("burnedge.central")


def serve_router(central: CentralConfig, stop: threading.Event | None = None) -> None:
    """Route until `stop` is set, or until SIGTERM or SIGINT when run as the main thread."""
    stop = stop or threading.Event()
    if threading.current_thread() is threading.main_thread():
        for signum in (signal.SIGTERM, signal.SIGINT):
            signal.signal(signum, lambda *_: stop.set())
    try:
        session = zenoh.open(router_session_config(central))
    except zenoh.ZError as exc:
        endpoints = ", ".join(central.listen_endpoints)
        raise LinkDown(f"the router cannot listen on {endpoints}: {str(exc).split(' at /')[0]}") from exc
    with session:
        log.info("center router listening on %s", ", ".join(central.listen_endpoints))
        stop.wait()
    log.info("center router stopped")
