"""A ~5 MB case over a 256 kbit/s link that is cut three times mid-transfer: it still arrives once, intact.

Clinic and center run in two network namespaces joined by a shaped veth pair (tests/poor_link.py NetnsLink);
where namespaces are unavailable, on loopback through a ThrottlingProxy at the same rate. Delivery is read from
both sites' SQLite files, since neither HTTP API is reachable from the host when the processes sit in namespaces.
"""

from __future__ import annotations

import contextlib
import json
import os
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.conftest import FAST_HASH_ENV, REPO, free_port
from tests.poor_link import NetnsLink, ThrottlingProxy
from tests.sync_sites import CENTER, Sites, cli, record_case

pytestmark = pytest.mark.server

RATE_KBIT = 256
OVERALL_TIMEOUT_S = 480.0
CUTS_AT = (0.20, 0.45, 0.70)  # share of chunks acknowledged at the clinic
DOWN_S = 4.0
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


def outbox_row(db: Path, bundle_id: str) -> sqlite3.Row:
    with contextlib.closing(sqlite3.connect(db, timeout=10)) as conn:
        conn.row_factory = sqlite3.Row
        return conn.execute("SELECT * FROM outbox WHERE bundle_id = ?", (bundle_id,)).fetchone()


def record_and_queue(sites: Sites, tmp_path: Path, photos: int = 4) -> tuple[str, str, list[Path]]:
    """Record a case with photos through the clinic's HTTP API on loopback, stop it, queue it with the CLI."""
    sites.gateway.start()
    try:
        encounter_id, paths = record_case(sites.clinic_client(), tmp_path, photos, seed=7, size=PHOTO_SIZE)
    finally:
        sites.gateway.stop()
    cli("--db", str(sites.gateway.db), "sync", "send", encounter_id, "--by", "clin", env=sites.gateway.env)
    with contextlib.closing(sqlite3.connect(sites.gateway.db)) as conn:
        (bundle_id,) = conn.execute("SELECT bundle_id FROM outbox WHERE encounter_id = ?", (encounter_id,)).fetchone()
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


def test_five_megabytes_over_256_kbit_with_three_cuts_arrive_once_and_intact(tmp_path: Path):
    started = time.monotonic()
    with poor_link(tmp_path) as (sites, link, start_both):
        encounter_id, bundle_id, photos = record_and_queue(sites, tmp_path)
        queued = outbox_row(sites.gateway.db, bundle_id)
        chunks, size = queued["chunks"], queued["bytes"]
        assert 4_500_000 < size < 7_000_000, f"bundle of {size} bytes, meant to be ~5 MB"
        print(f"bundle {bundle_id}: {size} bytes in {chunks} chunks; ideal {size * 8 / (RATE_KBIT * 1000):.0f} s")

        send_start = time.monotonic()
        procs = start_both()
        deadline = send_start + OVERALL_TIMEOUT_S
        cuts: list[tuple[float, int]] = []
        row = queued
        while True:
            row = outbox_row(sites.gateway.db, bundle_id)
            if row["state"] == "delivered":
                break
            for proc in procs:
                if proc.poll() is not None:
                    pytest.fail(
                        f"a site's process exited ({proc.returncode}); see {sites.gateway.log}, {sites.center.log}"
                    )
            if time.monotonic() > deadline:
                pytest.fail(
                    f"bundle {bundle_id} not delivered within {OVERALL_TIMEOUT_S:g} s over {RATE_KBIT} kbit/s: "
                    f"{row['sent_chunks']}/{chunks} chunks acknowledged, {row['attempts']} failed attempts, "
                    f"last error {row['last_error']!r}, cuts at {cuts}; see {sites.gateway.log} and "
                    f"{sites.center.log}"
                )
            if len(cuts) < len(CUTS_AT) and row["sent_chunks"] >= CUTS_AT[len(cuts)] * chunks:
                cuts.append((round(time.monotonic() - send_start, 1), row["sent_chunks"]))
                link.flap(DOWN_S)
            time.sleep(0.2)
        took = time.monotonic() - send_start
        print(
            f"delivered in {took:.0f} s (ideal {size * 8 / (RATE_KBIT * 1000):.0f} s), cuts (s, chunks acked) "
            f"{cuts}, {row['attempts']} failed attempts; whole test {time.monotonic() - started:.0f} s"
        )
        assert len(cuts) == len(CUTS_AT), f"the transfer finished before all cuts: {cuts}"
        assert row["sent_chunks"] == chunks

    with contextlib.closing(sqlite3.connect(sites.center.env["BURNEDGE_CENTRAL_DATABASE"])) as db:
        rows = db.execute("SELECT manifest FROM bundles WHERE bundle_id = ?", (bundle_id,)).fetchall()
        assert len(rows) == 1, f"{len(rows)} bundles rows for {bundle_id}"
        assert db.execute("SELECT COUNT(*) FROM bundles").fetchone()[0] == 1
        assert db.execute("SELECT COUNT(*) FROM incoming").fetchone()[0] == 0
    manifest = json.loads(rows[0][0])
    assert manifest["encounter_id"] == encounter_id
    parts = tmp_path / "burnedge-central-store" / "parts"
    received = sorted(
        (parts / p["sha256"][:2] / p["sha256"]).read_bytes()
        for p in manifest["parts"]
        if p["name"].startswith("photos/")
    )
    assert received == sorted(p.read_bytes() for p in photos), "photos differ after the transfer"
