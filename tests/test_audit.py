"""The audit trail: every write leaves an entry, and tampering is detected and located."""

from __future__ import annotations

import json
import sqlite3
import subprocess
import sys

from base.storage import audit
from harness.bodies import encounter_body, patient_body
from harness.processes import REPO


def _write_some_records(client, headers) -> None:
    p = patient_body()
    client.post("/api/v1/patients", json=p, headers=headers)
    client.put(f"/api/v1/patients/{p['id']}", json={**p, "weight_kg": 72}, headers={**headers, "If-Match": '"1"'})
    client.post("/api/v1/encounters", json=encounter_body(p["id"]), headers=headers)


def test_every_write_appends_an_entry_with_who_what_and_versions(client, auth, services):
    _write_some_records(client, auth["clinician"])
    entries = list(audit.entries(services.db.connection()))
    actions = [e.action for e in entries]
    assert actions.count("user.create") == 4 and actions.count("auth.login") == 4
    update = next(e for e in entries if e.action == "record.update")
    assert (update.kind, update.before_version, update.after_version) == ("patient", 1, 2)
    assert update.user_id is not None
    assert "assessment.compute" in actions
    for prev, entry in zip(entries, entries[1:], strict=False):
        assert entry.prev_hash == prev.hash and entry.seq == prev.seq + 1


def test_a_rejected_write_leaves_no_entry(client, auth, services):
    count = len(list(audit.entries(services.db.connection())))
    r = client.post("/api/v1/patients", json=patient_body(weight_kg=-3), headers=auth["clinician"])
    assert r.status_code == 400
    assert len(list(audit.entries(services.db.connection()))) == count


def test_verify_accepts_an_intact_chain(client, auth, services):
    _write_some_records(client, auth["clinician"])
    r = client.get("/api/v1/admin/audit/verify", headers=auth["admin"]).json()
    assert r["ok"] is True and r["first_broken_seq"] is None and r["entries"] > 10


def test_an_edited_entry_is_named(client, auth, services):
    _write_some_records(client, auth["clinician"])
    conn = services.db.connection()
    conn.execute("UPDATE audit_log SET user_id = 'someone-else' WHERE seq = 7")
    result = audit.verify(conn)
    assert not result.ok and result.first_broken_seq == 7 and "altered" in result.reason


def test_a_deleted_entry_is_named(client, auth, services):
    _write_some_records(client, auth["clinician"])
    conn = services.db.connection()
    conn.execute("DELETE FROM audit_log WHERE seq = 5")
    result = audit.verify(conn)
    assert not result.ok and result.first_broken_seq == 5 and "missing" in result.reason


def test_a_rewritten_entry_with_a_recomputed_hash_breaks_the_next_link(client, auth, services):
    _write_some_records(client, auth["clinician"])
    conn = services.db.connection()
    row = dict(conn.execute("SELECT * FROM audit_log WHERE seq = 6").fetchone())
    row["detail"] = "forged"
    row["hash"] = audit.entry_hash(row)
    conn.execute("UPDATE audit_log SET detail = ?, hash = ? WHERE seq = 6", (row["detail"], row["hash"]))
    result = audit.verify(conn)
    assert not result.ok and result.first_broken_seq == 7 and "previous-hash" in result.reason


def _cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "burnedge.cli", *args], capture_output=True, text=True, cwd=REPO)


def test_cli_audit_verify_exit_code_and_message(client, auth, services, config):
    _write_some_records(client, auth["clinician"])
    ok = _cli("--db", config.gateway.database, "audit", "verify")
    assert ok.returncode == 0 and json.loads(ok.stdout)["ok"] is True
    with sqlite3.connect(config.gateway.database) as raw:
        raw.execute("UPDATE audit_log SET action = 'nothing happened' WHERE seq = 9")
    broken = _cli("--db", config.gateway.database, "audit", "verify")
    assert broken.returncode == 6
    assert json.loads(broken.stdout)["first_broken_seq"] == 9


def test_cli_audit_verify_on_a_missing_database_says_so(tmp_path):
    r = _cli("--db", str(tmp_path / "nope.sqlite3"), "audit", "verify")
    assert r.returncode == 3 and "no database" in r.stderr
