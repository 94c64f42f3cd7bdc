"""The audit chain's head anchored at the burn center on every sync round, with both sites as real processes:
a clinic whose chain was cut back is told so by the center, even after the local anchor was deleted too."""

from __future__ import annotations

import json
import sqlite3

import pytest

from harness.bodies import patient_body
from harness.sites import CLINIC, Sites, cli, wait_for
from sync.anchor import ANCHOR_FILE
from tests.test_audit import _cli

pytestmark = pytest.mark.server


def _anchored(sites: Sites) -> list[tuple[int, str]]:
    with sqlite3.connect(sites.center.env["BURNEDGE_CENTRAL_DATABASE"]) as db:
        return db.execute("SELECT seq, hash FROM audit_anchors WHERE site_id = ? ORDER BY seq", (CLINIC,)).fetchall()


def _clinic_head(sites: Sites) -> tuple[int, str]:
    with sqlite3.connect(sites.gateway.db) as db:
        return db.execute("SELECT seq, hash FROM audit_log ORDER BY seq DESC LIMIT 1").fetchone()


def test_each_round_anchors_the_head_and_a_cut_back_chain_is_refused_by_the_center(sites: Sites):
    sites.center.start()
    sites.gateway.start()
    clinic = sites.clinic_client()
    clinic.post("/api/v1/patients", patient_body(), "patient")

    # The clinic's chain is anchored at its head within a round or two (rounds run every 0.5 s here).
    status = wait_for(
        lambda: (s := clinic.get("/api/v1/transfers/status", "status"))["audit_anchored_seq"] and s,
        30,
        "the first anchor",
    )
    assert status["audit_anchor_problem"] is None
    anchor_file = sites.folder / "burnedge-keys" / ANCHOR_FILE
    assert anchor_file.exists()
    assert status["audit_anchored_seq"] in [seq for seq, _ in _anchored(sites)]
    clinic.post("/api/v1/patients", patient_body(), "another patient")
    wait_for(lambda: _anchored(sites)[-1] == _clinic_head(sites), 30, "the anchor to follow the new head")

    sites.gateway.stop()
    ok = _cli("--db", str(sites.gateway.db), "audit", "verify")
    assert ok.returncode == 0 and "burn center's anchor" in json.loads(ok.stdout)["reason"]
    anchored_seq = _anchored(sites)[-1][0]

    # Someone cuts the last entries off the chain: the clinic sees it against the anchor it kept ...
    with sqlite3.connect(sites.gateway.db) as db:
        db.execute("DELETE FROM audit_log WHERE seq > ?", (anchored_seq - 4,))
    cut = _cli("--db", str(sites.gateway.db), "audit", "verify")
    assert cut.returncode == 6 and "were removed" in json.loads(cut.stdout)["reason"]

    # ... and when the anchor file goes too, the center still does, at the next round.
    anchor_file.unlink()
    sites.gateway.start()
    clinic = sites.clinic_client()
    problem = wait_for(
        lambda: clinic.get("/api/v1/transfers/status", "status")["audit_anchor_problem"], 30, "the center's refusal"
    )
    assert f"it had reached entry {anchored_seq}" in problem or f"entry {anchored_seq} is not the one" in problem
    assert _anchored(sites)[-1][0] == anchored_seq  # the center's anchor stayed where it was
    with sqlite3.connect(sites.center.env["BURNEDGE_CENTRAL_DATABASE"]) as db:
        codes = {r[0] for r in db.execute("SELECT code FROM rejections WHERE site_id = ?", (CLINIC,))}
    assert codes & {"audit-rollback", "audit-rewritten"}
    assert "refused to anchor" in sites.gateway.log.read_text()

    # It was a restore on purpose, say: the center's IT person accepts it and the restored chain is anchored afresh.
    accepted = json.loads(
        cli(
            "peers",
            "accept-restore",
            CLINIC,
            "--center",
            "--by",
            "it-person",
            "--reason",
            "restored from last night's backup",
            env=sites.center.env,
        )
    )
    assert accepted["anchors_voided"] >= 2 and accepted["last_anchored_seq"] == anchored_seq
    wait_for(
        lambda: clinic.get("/api/v1/transfers/status", "status")["audit_anchor_problem"] is None,
        30,
        "a fresh anchor after the accepted restore",
    )
    assert anchor_file.exists()
