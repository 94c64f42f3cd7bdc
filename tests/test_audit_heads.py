"""What the API serves against what the chain recorded, and the chain against the burn center's anchor
(issue 15: a rolled-back record and a truncated chain both passed `audit verify` before)."""

from __future__ import annotations

import json
import sqlite3
from pathlib import Path

import pytest

from base.storage import audit
from harness.bodies import patient_body
from schemas.audit import AuditAnchor, AuditHead
from schemas.base import iso, utcnow
from schemas.transfer import SiteRole
from sync.anchor import ANCHOR_FILE, save_anchor
from sync.keys import init_keys
from tests.test_audit import _cli


@pytest.fixture
def amended(client, auth):
    """A patient at version 2 (weight corrected)."""
    p = patient_body()
    client.post("/api/v1/patients", json=p, headers=auth["clinician"])
    r = client.put(
        f"/api/v1/patients/{p['id']}", json={**p, "weight_kg": 72}, headers={**auth["clinician"], "If-Match": '"1"'}
    )
    assert r.status_code == 200
    return p["id"]


def test_a_record_head_moved_back_to_an_older_version_is_named_and_exits_6(client, auth, config, amended):
    with sqlite3.connect(config.gateway.database) as raw:
        first = raw.execute("SELECT seq FROM record_versions WHERE id = ? AND version = 1", (amended,)).fetchone()[0]
        raw.execute("UPDATE record_heads SET seq = ? WHERE id = ?", (first, amended))
    assert client.get(f"/api/v1/patients/{amended}", headers=auth["clinician"]).json()["data"]["weight_kg"] == 70
    r = _cli("--db", config.gateway.database, "audit", "verify")
    result = json.loads(r.stdout)
    assert r.returncode == 6 and not result["ok"]
    assert f"patient {amended} is served at version 1" in result["reason"] and "rolled back" in result["reason"]


def test_a_record_written_outside_the_gateway_or_a_removed_head_is_named(services, amended):
    conn = services.db.connection()
    conn.execute("DELETE FROM record_heads WHERE id = ?", (amended,))
    result = audit.verify(conn)
    assert not result.ok and "no longer served" in result.reason
    conn.execute(
        "INSERT INTO record_heads (kind, id, seq, parent_id, deleted) SELECT kind, ?, seq, parent_id, 0"
        " FROM record_versions WHERE id = ? AND version = 2",
        ("0" * 8 + "-0000-7000-8000-" + "0" * 12, amended),
    )
    conn.execute(
        "INSERT INTO record_heads (kind, id, seq, parent_id, deleted) SELECT kind, id, seq, parent_id, 0"
        " FROM record_versions WHERE id = ? AND version = 2",
        (amended,),
    )
    result = audit.verify(conn)
    assert not result.ok and "no audit entry records it" in result.reason


def _anchor_at(config, seq: int, digest: str) -> Path:
    """The anchor a burn center would have signed, in the clinic's keys folder (no center enrolled here, so its
    content is checked, not its signature)."""
    center = init_keys(Path(config.gateway.database).parent / "center-keys", "center-test", SiteRole.center, "C")
    anchor = AuditAnchor(
        site_id="clinic-test", center_id="center-test", head=AuditHead(seq=seq, hash=digest), anchored_at=iso(utcnow())
    )
    path = Path(config.gateway.database).parent / "burnedge-keys" / ANCHOR_FILE
    save_anchor(path, center.sign("audit-anchor", anchor))
    return path


def test_a_chain_cut_back_below_the_anchor_is_named_and_exits_6(services, config, amended):
    conn = services.db.connection()
    head = audit.head(conn)
    _anchor_at(config, head.seq, head.hash)
    ok = _cli("--db", config.gateway.database, "audit", "verify")
    assert ok.returncode == 0 and f"anchor (entry {head.seq}" in json.loads(ok.stdout)["reason"]
    with sqlite3.connect(config.gateway.database) as raw:
        raw.execute("DELETE FROM audit_log WHERE seq > ?", (head.seq - 3,))
    r = _cli("--db", config.gateway.database, "audit", "verify")
    result = json.loads(r.stdout)
    assert r.returncode == 6 and result["first_broken_seq"] == head.seq
    assert f"entries {head.seq - 2} to {head.seq} were removed" in result["reason"]


def test_a_chain_rewritten_up_to_the_anchor_and_a_damaged_anchor_file_are_named(services, config, amended):
    conn = services.db.connection()
    head = audit.head(conn)
    path = _anchor_at(config, head.seq, "f" * 64)
    r = _cli("--db", config.gateway.database, "audit", "verify")
    assert r.returncode == 6 and "was rewritten" in json.loads(r.stdout)["reason"]
    path.write_bytes(path.read_bytes()[:-20])
    r = _cli("--db", config.gateway.database, "audit", "verify")
    assert r.returncode == 6 and "unreadable" in json.loads(r.stdout)["reason"]
