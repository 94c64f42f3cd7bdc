"""Both sites' processes across a slow, breakable link at 256 kbit/s, for the poor-link test and the transfer
benchmark: two network namespaces joined by a shaped veth pair (harness/poor_link.py NetnsLink) where the kernel
allows them, else loopback through a ThrottlingProxy at the same rate."""

from __future__ import annotations

import contextlib
import os
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

from harness.poor_link import NetnsLink, ThrottlingProxy
from harness.processes import FAST_HASH_ENV, REPO, free_port
from harness.sites import CENTER, Sites, cli, record_case
from schemas.transfer import OutboxEntry
from sync.storage import outbox as outbox_store

RATE_KBIT = 256
PHOTO_SIZE = (1500, 1120)  # ~1.3 MB of JPEG each
SLOW_LINK_ENV = {
    "BURNEDGE_SYNC_CHUNK_KIB": "64",
    "BURNEDGE_SYNC_WINDOW_CHUNKS": "4",
    "BURNEDGE_SYNC_QUERY_TIMEOUT_S": "60",
    "BURNEDGE_SYNC_CONNECT_TIMEOUT_S": "5",
    "BURNEDGE_SYNC_RETRY_BASE_S": "0.5",
    "BURNEDGE_SYNC_RETRY_MAX_S": "3",
    "BURNEDGE_SYNC_INTERVAL_S": "1",
}


def outbox_entry(db: Path, bundle_id: str) -> OutboxEntry:
    """The bundle as the clinic's outbox holds it now, read from its SQLite file while the gateway may write."""
    with contextlib.closing(_connect(db, timeout=10)) as conn:
        return outbox_store.get(conn, bundle_id).entry


def record_and_queue(sites: Sites, tmp_path: Path, photos: int = 4) -> tuple[str, str, list[Path]]:
    """Record a case with photos through the clinic's HTTP API on loopback, stop it, queue it with the CLI."""
    sites.gateway.start()
    try:
        encounter_id, paths = record_case(sites.clinic_client(), tmp_path, photos, seed=7, size=PHOTO_SIZE)
    finally:
        sites.gateway.stop()
    cli("--db", str(sites.gateway.db), "sync", "send", encounter_id, "--by", "clin", env=sites.gateway.env)
    with contextlib.closing(_connect(sites.gateway.db)) as conn:
        bundle_id = outbox_store.entries(conn, encounter_id, limit=1)[0].bundle_id
    return encounter_id, bundle_id, paths


def wait_ready(log: Path, proc: subprocess.Popen, needle: str, what: str, timeout: float = 60.0) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise RuntimeError(f"{what} exited early: {log.read_text(errors='replace')[-3000:]}")
        if log.exists() and needle in log.read_text(errors="replace"):
            return
        time.sleep(0.2)
    raise RuntimeError(f"{what} not ready after {timeout:g} s: {log.read_text(errors='replace')[-3000:]}")


def start_center_in(link: NetnsLink, sites: Sites) -> subprocess.Popen:
    env = {**os.environ, **FAST_HASH_ENV, **sites.center.env}
    with open(sites.center.log, "ab") as log:
        proc = link.popen(
            "center",
            [sys.executable, "-m", "burnedge.cli", "central", "--site-id", CENTER, "--name", "Test burn center"],
            cwd=REPO,
            env=env,
            stdout=log,
            stderr=subprocess.STDOUT,
        )
    wait_ready(sites.center.log, proc, f"center {CENTER} listening on", "the center")
    return proc


def start_gateway_in(link: NetnsLink, sites: Sites) -> subprocess.Popen:
    env = {**os.environ, **FAST_HASH_ENV, **sites.gateway.env}
    with open(sites.gateway.log, "ab") as log:
        # Its HTTP API is on the namespace's own loopback, out of the host's reach: the test watches the outbox.
        return link.popen(
            "clinic",
            [
                sys.executable,
                "-m",
                "burnedge.cli",
                "--db",
                str(sites.gateway.db),
                "serve",
                "--port",
                str(sites.gateway.port),
            ],
            cwd=REPO,
            env=env,
            stdout=log,
            stderr=subprocess.STDOUT,
        )


@contextlib.contextmanager
def poor_link(tmp_path: Path):
    """(sites, cut) with both sites' processes running across a 256 kbit/s link; `cut(s)` takes it down for s."""
    ok, why = NetnsLink.available()
    if ok:
        with NetnsLink(RATE_KBIT) as link:
            sites = Sites(tmp_path, center_endpoint=f"tcp/{link.center_ip}:7447")
            sites.center.env["BURNEDGE_CENTRAL_LISTEN_ENDPOINTS"] = f"tcp/{link.center_ip}:7447"
            sites.gateway.env.update(SLOW_LINK_ENV)
            sites.set_up()
            yield sites, link, lambda: (start_center_in(link, sites), start_gateway_in(link, sites))
        return
    print(f"NetnsLink unavailable ({why}): ThrottlingProxy on loopback")
    zenoh_port = free_port()
    with ThrottlingProxy("127.0.0.1", zenoh_port, rate_kbit=RATE_KBIT) as proxy:
        sites = Sites(tmp_path, center_endpoint=f"tcp/127.0.0.1:{proxy.port}", zenoh_port=zenoh_port)
        sites.gateway.env.update(SLOW_LINK_ENV)
        sites.set_up()
        try:
            yield sites, proxy, lambda: (sites.center.start().proc, sites.gateway.start().proc)
        finally:
            sites.stop()


def _connect(db: Path, timeout: float = 5.0) -> sqlite3.Connection:
    conn = sqlite3.connect(db, timeout=timeout)
    conn.row_factory = sqlite3.Row
    return conn
