"""The center under load, on loopback: simulated clinics (each its own gateway database, keys and Zenoh session,
sending with the gateway's own outbox and sync round) in two processes send three cases each to a router with two
workers on PostgreSQL; one worker is SIGKILLed mid-run and restarted. Every case arrives once, byte for byte, and
every receipt is back at its clinic. benchmarks/center_load.py runs the same with 200 clinics and 1-5 MB cases."""

from __future__ import annotations

import hashlib
from pathlib import Path

import pytest

from center.app import open_center_db
from center.cases import CaseService
from harness.center_load import LoadCenter, run_load
from harness.sim_clinics import photo_digest
from sync.keys import load_keys
from tests.conftest import CONSULTANT

pytestmark = pytest.mark.server
CLINICS, CASES = 24, 3


def test_clinics_under_load_with_a_worker_killed_get_every_case_stored_once(tmp_path: Path, postgres_server):
    center = LoadCenter(tmp_path / "center", postgres_server.create_database("load"), workers=2)
    try:
        run = run_load(
            center,
            tmp_path / "clinics",
            clinics=CLINICS,
            cases=CASES,
            min_mb=0.3,
            max_mb=1.5,
            processes=2,
            threads=4,
            kill_after=10,
            timeout_s=300,
        )
    finally:
        center.stop()
    assert run.killed_at == 10 and run.restarted_at is not None and run.undelivered == 0
    assert len(run.delivered) == CLINICS * CASES == len({d["bundle_id"] for d in run.delivered})

    db = open_center_db(center.central)
    try:
        rows = db.connection().execute("SELECT site_id, bundle_id FROM bundles").fetchall()
        assert sorted(r["bundle_id"] for r in rows) == sorted(d["bundle_id"] for d in run.delivered)
        assert db.connection().execute("SELECT COUNT(*) FROM incoming").fetchone()[0] == 0
        service = CaseService(db, load_keys(Path(center.central.keys_dir)), Path(center.central.store_dir))
        for case in run.delivered:
            photo, _ = service.part(CONSULTANT, case["clinic"], case["bundle_id"], "photos/case.jpg")
            assert hashlib.sha256(photo).hexdigest() == photo_digest(case["bytes"], case["seed"])
    finally:
        db.close()
    staging = Path(center.central.store_dir) / "incoming"
    assert not any(p.is_file() for p in staging.rglob("*")), "staged chunks left behind"
