"""A ~5 MB case over a 256 kbit/s link that is cut three times mid-transfer: it still arrives once, intact.

Clinic and center run in two network namespaces joined by a shaped veth pair (harness/poor_link.py NetnsLink);
where namespaces are unavailable, on loopback through a ThrottlingProxy at the same rate. Delivery is read from
both sites' SQLite files, since neither HTTP API is reachable from the host when the processes sit in namespaces.
"""

from __future__ import annotations

import contextlib
import json
import sqlite3
import time
from pathlib import Path

import msgspec
import pytest

from center.app import open_center_db
from center.cases import CaseService
from harness.poor_link_sites import RATE_KBIT, outbox_entry, poor_link, record_and_queue
from schemas.config import CentralConfig
from sync.keys import load_keys
from tests.conftest import CONSULTANT

pytestmark = pytest.mark.server

OVERALL_TIMEOUT_S = 480.0
CUTS_AT = (0.20, 0.45, 0.70)  # share of chunks acknowledged at the clinic
DOWN_S = 4.0


def test_five_megabytes_over_256_kbit_with_three_cuts_arrive_once_and_intact(tmp_path: Path):
    started = time.monotonic()
    with poor_link(tmp_path) as (sites, link, start_both):
        encounter_id, bundle_id, photos = record_and_queue(sites, tmp_path)
        queued = outbox_entry(sites.gateway.db, bundle_id)
        chunks, size = queued.chunks, queued.bytes
        assert 4_500_000 < size < 7_000_000, f"bundle of {size} bytes, meant to be ~5 MB"
        print(f"bundle {bundle_id}: {size} bytes in {chunks} chunks; ideal {size * 8 / (RATE_KBIT * 1000):.0f} s")

        send_start = time.monotonic()
        procs = start_both()
        deadline = send_start + OVERALL_TIMEOUT_S
        cuts: list[tuple[float, int]] = []
        row = queued
        while True:
            row = outbox_entry(sites.gateway.db, bundle_id)
            if row.state == "delivered":
                break
            for proc in procs:
                if proc.poll() is not None:
                    pytest.fail(
                        f"a site's process exited ({proc.returncode}); see {sites.gateway.log}, {sites.center.log}"
                    )
            if time.monotonic() > deadline:
                pytest.fail(
                    f"bundle {bundle_id} not delivered within {OVERALL_TIMEOUT_S:g} s over {RATE_KBIT} kbit/s: "
                    f"{row.sent_chunks}/{chunks} chunks acknowledged, {row.attempts} failed attempts, "
                    f"last error {row.last_error!r}, cuts at {cuts}; see {sites.gateway.log} and "
                    f"{sites.center.log}"
                )
            if len(cuts) < len(CUTS_AT) and row.sent_chunks >= CUTS_AT[len(cuts)] * chunks:
                cuts.append((round(time.monotonic() - send_start, 1), row.sent_chunks))
                link.flap(DOWN_S)
            time.sleep(0.2)
        took = time.monotonic() - send_start
        print(
            f"delivered in {took:.0f} s (ideal {size * 8 / (RATE_KBIT * 1000):.0f} s), cuts (s, chunks acked) "
            f"{cuts}, {row.attempts} failed attempts; whole test {time.monotonic() - started:.0f} s"
        )
        assert len(cuts) == len(CUTS_AT), f"the transfer finished before all cuts: {cuts}"
        assert row.sent_chunks == chunks

    with contextlib.closing(sqlite3.connect(sites.center.env["BURNEDGE_CENTRAL_DATABASE"])) as db:
        rows = db.execute("SELECT manifest FROM bundles WHERE bundle_id = ?", (bundle_id,)).fetchall()
        assert len(rows) == 1, f"{len(rows)} bundles rows for {bundle_id}"
        assert db.execute("SELECT COUNT(*) FROM bundles").fetchone()[0] == 1
        assert db.execute("SELECT COUNT(*) FROM incoming").fetchone()[0] == 0
    manifest = json.loads(rows[0][0])
    assert manifest["encounter_id"] == encounter_id
    env = sites.center.env
    central = CentralConfig(
        database=env["BURNEDGE_CENTRAL_DATABASE"],
        store_dir=env["BURNEDGE_CENTRAL_STORE_DIR"],
        keys_dir=env["BURNEDGE_CENTRAL_KEYS_DIR"],
    )
    center_db = open_center_db(central)
    try:  # the center keeps the sealed chunks: read the photos back as a consultant's download decrypts them
        service = CaseService(center_db, load_keys(Path(central.keys_dir)), Path(central.store_dir))
        site_id = msgspec.json.decode(rows[0][0])["site_id"]
        received = sorted(
            service.part(CONSULTANT, site_id, bundle_id, p["name"])[0]
            for p in manifest["parts"]
            if p["name"].startswith("photos/")
        )
    finally:
        center_db.close()
    assert received == sorted(p.read_bytes() for p in photos), "photos differ after the transfer"
