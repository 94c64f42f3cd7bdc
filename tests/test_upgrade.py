"""Upgrades: a gateway and a burn center whose files were written by older versions (tests/fixtures/upgrade, see its
README) are migrated to the current head; every row, stored file and audit entry they held must come through, and
the current code must serve them."""

from __future__ import annotations

import hashlib
import json
import shutil
import sqlite3
import subprocess
import sys
from collections import Counter
from pathlib import Path

import pytest
import sqlite_utils
from litestar.testing import TestClient

from center.app import CentralServices, create_central_app
from center.storage.migrations import central_migrations
from gateway.app import create_app
from gateway.storage.database import Database
from gateway.storage.migrations import migrations
from harness.processes import FAST_HASH_ENV, REPO, login
from schemas.config import CentralConfig, Config, GatewayConfig
from tests.conftest import FAST_SECURITY

FIXTURES = Path(__file__).parent / "fixtures" / "upgrade"
Snapshot = dict[str, tuple[list[str], Counter]]
"""table -> (its columns, its rows as a multiset of tuples)."""


def snapshot(db: Path) -> Snapshot:
    conn = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    try:
        tables = [r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type = 'table' ORDER BY name")]
        out: Snapshot = {
            "sqlite_master": (
                ["type", "name", "sql"],
                Counter(conn.execute("SELECT type, name, sql FROM sqlite_master")),
            )
        }
        for table in tables:
            cursor = conn.execute(f'SELECT * FROM "{table}"')
            out[table] = ([d[0] for d in cursor.description], Counter(cursor.fetchall()))
        return out
    finally:
        conn.close()


def rows(snap: Snapshot, table: str) -> list[dict]:
    columns, counted = snap[table]
    return [dict(zip(columns, row, strict=True)) for row in counted.elements()]


def assert_kept(before: Snapshot, after: Snapshot) -> None:
    """Every table, column and row there was is still there with the same values (new columns and rows may come)."""
    for table, (columns, old_rows) in before.items():
        if table == "sqlite_master":
            continue
        if table == "sqlite_sequence":  # AUTOINCREMENT counters: a migration that writes rows moves them on
            counters = {name: seq for name, seq in after[table][1]}
            assert all(counters.get(name, -1) >= seq for name, seq in old_rows), "a sequence went back"
            continue
        assert table in after, f"table {table} is gone"
        new_columns, new_rows = after[table]
        lost = [c for c in columns if c not in new_columns]
        assert not lost, f"{table}: columns {lost} are gone"
        index = [new_columns.index(c) for c in columns]
        projected = Counter({tuple(row[i] for i in index): n for row, n in new_rows.items()})
        missing = old_rows - projected
        assert not missing, f"{table}: {sum(missing.values())} rows lost or changed, e.g. {next(iter(missing))}"


def file_hashes(root: Path) -> dict[str, str]:
    return {
        str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(root.rglob("*"))
        if p.is_file()
    }


def migrate(db_path: Path, migration_set) -> list[str]:
    db = Database(db_path)
    try:
        return db.migrate(migration_set)
    finally:
        db.close()


def upgraded(tmp_path: Path, name: str, db_name: str, migration_set, stores: list[str]) -> tuple[Path, Snapshot]:
    """The fixture copied to tmp_path, migrated twice; its snapshot from before. Checks what survived."""
    folder = shutil.copytree(FIXTURES / name, tmp_path / name, ignore=shutil.ignore_patterns("*-wal", "*-shm"))
    db_path = folder / db_name
    before = snapshot(db_path)
    files = {store: file_hashes(folder / store) for store in stores}
    assert all(files.values()), f"the {name} fixture has no stored files"
    old_names = {r["name"] for r in rows(before, "_sqlite_migrations")}
    head = [m.name for m in migration_set.pending(sqlite_utils.Database(memory=True))]  # every one, in order

    applied = migrate(db_path, migration_set)
    assert applied == [n for n in head if n not in old_names]
    after = snapshot(db_path)
    assert_kept(before, after)
    assert {r["name"] for r in rows(after, "_sqlite_migrations")} >= set(head)

    assert migrate(db_path, migration_set) == [], "a second migration must find nothing to do"
    assert snapshot(db_path) == after, "a second migration changed the database"
    for store, hashes in files.items():
        assert file_hashes(folder / store) == hashes, f"{store}: stored files changed"
        for relative, sha in hashes.items():  # content-addressed: named by their SHA-256
            if not relative.endswith((".json", ".key")):
                assert Path(relative).name == sha, f"{store}/{relative} no longer holds the bytes it is named by"
    return db_path, before


def served_head(client: TestClient, headers: dict, head: dict) -> dict:
    """A record as its own endpoint serves it; an encounter's parts as the whole encounter record serves them."""
    if head["kind"] in ("patient", "encounter"):
        r = client.get(f"/api/v1/{head['kind']}s/{head['id']}", headers=headers)
        assert r.status_code == 200, r.text
        return r.json()
    r = client.get(f"/api/v1/encounters/{head['parent_id']}/record", headers=headers)
    assert r.status_code == 200, r.text
    return r.json()["parts"][head["kind"]]


def test_a_gateway_made_before_sync_is_migrated_with_every_record_file_and_audit_entry(tmp_path: Path):
    db_path, before = upgraded(tmp_path, "gateway", "gateway.sqlite3", migrations, ["burnedge-media"])
    old_migrations = {r["name"] for r in rows(before, "_sqlite_migrations")}
    assert "m006_analysis_jobs" in old_migrations and "m007_sync" not in old_migrations, "made before m007_sync"
    check_gateway_serves(db_path, before, "gateway")


def test_a_gateway_made_by_the_main_before_the_layers_migrates_and_serves_as_before(tmp_path: Path):
    """Made by commit 4bb4a92, the last before the shared base and center/ (issue 17): the schema is at m009."""
    db_path, before = upgraded(tmp_path, "gateway-4bb4a92", "gateway.sqlite3", migrations, ["burnedge-media"])
    assert "m009_capture_time_and_attempts" in {r["name"] for r in rows(before, "_sqlite_migrations")}
    check_gateway_serves(db_path, before, "gateway-4bb4a92")


def check_gateway_serves(db_path: Path, before: Snapshot, name: str) -> None:
    """The migrated gateway serves every record version, file, job and audit entry the fixture held."""
    versions, heads, assets = rows(before, "record_versions"), rows(before, "record_heads"), rows(before, "assets")
    assert any(v["version"] > 1 and not v["deleted"] for v in versions), "the fixture should hold an amendment"
    assert any(v["deleted"] for v in versions), "the fixture should hold a withdrawn record"
    assert assets and rows(before, "analysis_jobs") and rows(before, "devices")
    blobs = db_path.parent / "burnedge-media" / "blobs"
    for asset in assets:
        assert (
            hashlib.sha256((blobs / asset["sha256"][:2] / asset["sha256"]).read_bytes()).hexdigest() == asset["sha256"]
        )

    verified = subprocess.run(
        [sys.executable, "-m", "burnedge.cli", "--db", str(db_path), "audit", "verify"],
        capture_output=True,
        text=True,
        cwd=REPO,
        env={**FAST_HASH_ENV, "PATH": ""},
    )
    assert verified.returncode == 0, verified.stdout + verified.stderr
    result = json.loads(verified.stdout)
    upgrade_wounds = check_one_wound_per_patient_with_analyses(db_path, before)
    assert result["ok"] and result["entries"] == len(rows(before, "audit_log")) + len(upgrade_wounds), result

    config = Config(gateway=GatewayConfig(database=str(db_path)), security=FAST_SECURITY)
    with TestClient(create_app(config)) as client:
        clin, admin = login(client, "clin"), login(client, "admin")
        for r in rows(before, "users"):
            assert login(client, r["username"]), r["username"]

        # The change feed serves every version ever written, unchanged.
        fed, cursor = [], 0
        while True:
            page = client.get("/api/v1/sync/changes", params={"since": cursor, "limit": 100}, headers=clin).json()
            fed += page["changes"]
            cursor = page["next_cursor"]
            if not page["has_more"]:
                break
        served = {(c["meta"]["kind"], c["meta"]["id"], c["meta"]["version"]): c for c in fed}
        assert len(served) == len(versions) + len(upgrade_wounds)
        for wound_id, patient_id in upgrade_wounds.items():
            wound = client.get(f"/api/v1/wounds/{wound_id}", headers=clin).json()
            assert wound["data"]["patient_id"] == patient_id and served[("wound", wound_id, 1)]
            healing = client.get(f"/api/v1/patients/{patient_id}/healing", headers=clin).json()
            assert [w["wound_id"] for w in healing["wounds"]] == [wound_id], healing
        for v in versions:
            got = served[(v["kind"], v["id"], v["version"])]
            assert got["data"] == json.loads(v["data"]) and got["meta"]["seq"] == v["seq"]
            assert (got["meta"]["deleted"], got["meta"]["delete_reason"], got["meta"]["updated_by"]) == (
                bool(v["deleted"]),
                v["delete_reason"],
                v["updated_by"],
            )

        # Each record as its own endpoint serves it: the head, and for patients and encounters every version.
        by_seq = {v["seq"]: v for v in versions}
        for h in heads:
            head, got = by_seq[h["seq"]], served_head(client, clin, h)
            assert (got["meta"]["version"], got["meta"]["deleted"], got["data"]) == (
                head["version"],
                bool(head["deleted"]),
                json.loads(head["data"]),
            )
            if h["kind"] in ("patient", "encounter"):
                history = client.get(f"/api/v1/{h['kind']}s/{h['id']}/history", headers=clin).json()["versions"]
                assert [x["meta"]["version"] for x in history] == sorted(
                    v["version"] for v in versions if (v["kind"], v["id"]) == (h["kind"], h["id"])
                )

        for asset in assets:
            file = client.get(f"/api/v1/assets/{asset['id']}/file", headers=clin)
            assert file.status_code == 200 and hashlib.sha256(file.content).hexdigest() == asset["sha256"]
        for job in rows(before, "analysis_jobs"):
            assert client.get(f"/api/v1/analyses/{job['id']}", headers=clin).json()["state"] == job["state"]
        # The old chain is served as written, and this session's logins went on from its end.
        old_chain = sorted(rows(before, "audit_log"), key=lambda e: e["seq"])
        audit = client.get("/api/v1/admin/audit", params={"after": 0, "limit": 1000}, headers=admin).json()
        assert [(e["seq"], e["hash"]) for e in audit[: len(old_chain)]] == [(e["seq"], e["hash"]) for e in old_chain]
        assert len(audit) > len(old_chain) and audit[len(old_chain)]["prev_hash"] == old_chain[-1]["hash"]
        assert client.get("/api/v1/admin/audit/verify", headers=admin).json()["ok"]
    assert file_hashes(db_path.parent / "burnedge-media") == file_hashes(FIXTURES / name / "burnedge-media")


def check_one_wound_per_patient_with_analyses(db_path: Path, before: Snapshot) -> dict[str, str]:
    """The upgrade gave each patient with analyses one wound holding all of them and their encounters' pictures,
    and no other patient a wound. Returns wound id -> patient id."""
    conn = sqlite3.connect(f"file:{db_path}?mode=ro", uri=True)
    conn.row_factory = sqlite3.Row
    try:
        wounds = {
            r["id"]: r["parent_id"]
            for r in conn.execute("SELECT id, parent_id FROM record_heads WHERE kind = 'wound'").fetchall()
        }
        jobs = conn.execute("SELECT id, patient_id, encounter_id, wound_id FROM analysis_jobs").fetchall()
        assets = conn.execute("SELECT encounter_id, wound_id FROM assets").fetchall()
    finally:
        conn.close()
    patients = {j["patient_id"] for j in rows(before, "analysis_jobs")}
    assert sorted(wounds.values()) == sorted(patients), "one wound per patient with analyses, and only them"
    for job in jobs:
        assert wounds[job["wound_id"]] == job["patient_id"], f"job {job['id']} is not in its patient's wound"
    analysed = {j["encounter_id"]: j["wound_id"] for j in jobs}
    for asset in assets:
        assert asset["wound_id"] == analysed.get(asset["encounter_id"]), "a picture is not in its wound"
    return wounds


CENTER_STORES = ["burnedge-central-store", "burnedge-central-keys"]


def test_a_center_made_by_an_older_schema_is_migrated_and_still_serves_its_cases(tmp_path: Path):
    db_path, before = upgraded(tmp_path, "center", "center.sqlite3", central_migrations, CENTER_STORES)
    check_center_serves(db_path, before)


def test_a_center_made_by_the_main_before_the_layers_migrates_and_serves_as_before(tmp_path: Path):
    """Made by commit 4bb4a92, the last before center/ moved out of sync/central (issue 17): schema at c003."""
    db_path, before = upgraded(tmp_path, "center-4bb4a92", "center.sqlite3", central_migrations, CENTER_STORES)
    assert "c003_must_change_password" in {r["name"] for r in rows(before, "_sqlite_migrations")}
    check_center_serves(db_path, before)


def check_center_serves(db_path: Path, before: Snapshot) -> None:
    """The migrated center lists and serves every case, part, note, rejection and site the fixture held."""
    bundles, parts, notes = rows(before, "bundles"), rows(before, "bundle_parts"), rows(before, "notes")
    assert len(bundles) == 2 and parts and notes and rows(before, "rejections") and rows(before, "peers")

    config = Config(central=CentralConfig(database=str(db_path)), security=FAST_SECURITY)
    db = Database(db_path)
    services = CentralServices.build(config, db)
    try:
        with TestClient(create_central_app(config, services)) as client:
            consultant, admin = login(client, "consult"), login(client, "centeradmin")
            latest = client.get("/api/v1/cases", headers=consultant).json()["cases"]
            newest = next(b for b in bundles if not any(o["supersedes"] == b["bundle_id"] for o in bundles))
            assert [(c["bundle_id"], c["version"]) for c in latest] == [(newest["bundle_id"], newest["version"])]
            every = client.get("/api/v1/cases", params={"include_superseded": True}, headers=consultant).json()["cases"]
            assert sorted(c["bundle_id"] for c in every) == sorted(b["bundle_id"] for b in bundles)
            for b in bundles:
                case = f"/api/v1/cases/{b['site_id']}/{b['bundle_id']}"
                detail = client.get(case, headers=consultant).json()
                assert detail["case"]["encounter_id"] == b["encounter_id"]
                # An encounter's notes show on each of its versions, with when the clinic confirmed them.
                written = [n for n in notes if (n["site_id"], n["encounter_id"]) == (b["site_id"], b["encounter_id"])]
                assert [(n["note"]["note_id"], n["delivered_at"]) for n in detail["notes"]] == [
                    (n["note_id"], n["delivered_at"]) for n in sorted(written, key=lambda n: n["seq"])
                ]
                mine = [p for p in parts if p["bundle_id"] == b["bundle_id"]]
                assert sorted(p["name"] for p in detail["manifest"]["parts"]) == sorted(p["name"] for p in mine)
                for p in mine:
                    got = client.get(f"{case}/parts/{p['name']}", headers=consultant)
                    assert got.status_code == 200 and hashlib.sha256(got.content).hexdigest() == p["sha256"]
            refused = client.get("/api/v1/rejections", headers=admin).json()
            assert [r["code"] for r in refused] == [r["code"] for r in rows(before, "rejections")]
            sites = {s["identity"]["site_id"]: s for s in client.get("/api/v1/sites", headers=admin).json()}
            assert set(sites) == {p["site_id"] for p in rows(before, "peers")}
            assert any(s["revoked_at"] for s in sites.values())
    finally:
        db.close()


@pytest.mark.parametrize("name", ["gateway", "center", "gateway-4bb4a92", "center-4bb4a92"])
def test_the_fixtures_are_small_and_self_contained(name: str):
    folder = FIXTURES / name
    files = [p for p in folder.rglob("*") if p.is_file() and not p.name.endswith(("-wal", "-shm"))]
    assert sum(p.stat().st_size for p in files) < 512 * 1024
    # A -wal/-shm pair appears when SQLite merely opens the file (they are ignored by git): the WAL must be empty.
    assert all(p.stat().st_size == 0 for p in folder.glob("*.sqlite3-wal")), "checkpoint the WAL into the file"
