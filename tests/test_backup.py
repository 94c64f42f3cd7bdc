"""Backup and restore of the whole gateway state: online under a write burst, encrypted, verified before writing."""

from __future__ import annotations

import hashlib
import os
import sqlite3
import subprocess
import sys
import threading
import time
from pathlib import Path

import msgspec
import pytest

from burnedge.demo_client import GatewayClient
from gateway.backup import snapshot
from gateway.backup.stream import MAGIC
from gateway.storage.database import Database
from harness.bodies import patient_body
from harness.processes import FAST_HASH_ENV, PASSWORD, REPO, free_port, wait_healthy
from harness.sites import Sites, cli, record_case
from schemas.config import Config, GatewayConfig
from schemas.ids import uuid7

PASSPHRASE = "horse staple battery correct"
# Argon2id at its cheapest and small chunks, so that a test backup spans several chunks.
FAST_BACKUP_ENV = {
    "BURNEDGE_BACKUP_KDF_OPSLIMIT": "1",
    "BURNEDGE_BACKUP_KDF_MEMORY_KIB": "8",
    "BURNEDGE_BACKUP_CHUNK_KIB": "16",
    "BACKUP_PASSPHRASE": PASSPHRASE,
}


def burnedge(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "burnedge.cli", *args],
        capture_output=True,
        text=True,
        cwd=REPO,
        env={**os.environ, **FAST_HASH_ENV, **FAST_BACKUP_ENV, **(env or {})},
        timeout=120,
    )


def serve(config: Path, folder: Path) -> tuple[subprocess.Popen, str]:
    port = free_port()
    log = folder / "restored-gateway.log"
    with open(log, "ab") as out:
        proc = subprocess.Popen(
            [sys.executable, "-m", "burnedge.cli", "--config", str(config), "serve", "--port", str(port)],
            cwd=REPO,
            stdout=out,
            stderr=subprocess.STDOUT,
            env={**os.environ, "BURNEDGE_JOBS_WORKERS": "0"},
        )
    url = f"http://127.0.0.1:{port}"
    wait_healthy(proc, url, log, 30, "restored gateway")
    return proc, url


class WriteBurst(threading.Thread):
    """Creates patients through the HTTP API as fast as it can; keeps each acknowledged write with its time."""

    def __init__(self, url: str):
        super().__init__(daemon=True)
        self.client = GatewayClient(url)
        self.client.login("clin", PASSWORD)
        self.acknowledged: list[tuple[float, str]] = []
        self.stop = threading.Event()

    def run(self) -> None:
        while not self.stop.is_set():
            body = patient_body(uuid7())
            self.client.post("/api/v1/patients", body, "patient")
            self.acknowledged.append((time.monotonic(), body["id"]))


@pytest.fixture
def served_state(tmp_path: Path):
    """A clinic gateway process with keys, an enrolled center, photos and a case queued in the outbox."""
    sites = Sites(tmp_path)
    sites.set_up()
    sites.gateway.env.update({"BURNEDGE_SYNC_ENABLED": "false", "BURNEDGE_JOBS_WORKERS": "0"})
    sites.gateway.start()
    client = sites.clinic_client()
    encounter_id, _ = record_case(client, tmp_path, photos=3, size=(1000, 750))
    cli("--db", str(sites.gateway.db), "sync", "send", encounter_id, "--by", "clin")
    yield sites
    sites.stop()


def test_a_backup_taken_under_a_write_burst_restores_every_acknowledged_write(served_state, tmp_path):
    sites = served_state
    db = sites.gateway.db
    burst = WriteBurst(sites.gateway.url)
    burst.start()
    while len(burst.acknowledged) < 20:
        time.sleep(0.01)
    started = time.monotonic()
    made = burnedge(
        "--db",
        str(db),
        "backup",
        "--out",
        str(tmp_path / "nightly.burnedge-backup"),
        "--passphrase-env",
        "BACKUP_PASSPHRASE",
    )
    finished = time.monotonic()
    time.sleep(0.2)
    burst.stop.set()
    burst.join(10)
    assert made.returncode == 0, made.stderr
    before = [pid for at, pid in burst.acknowledged if at < started]
    during = [pid for at, pid in burst.acknowledged if started <= at < finished]
    assert during, "the burst must go on while the backup runs"
    summary = msgspec.json.decode(made.stdout)
    assert summary["skipped"] == [] and summary["audit_head"]["seq"] > 0

    into = tmp_path / "restored"
    restored = burnedge(
        "restore",
        str(tmp_path / "nightly.burnedge-backup"),
        "--into",
        str(into),
        "--passphrase-env",
        "BACKUP_PASSPHRASE",
    )
    assert restored.returncode == 0, restored.stderr
    config = into / "burnedge.toml"
    verified = burnedge("--config", str(config), "audit", "verify")
    assert verified.returncode == 0, verified.stdout + verified.stderr

    with sqlite3.connect(into / db.name) as conn:
        last = conn.execute("SELECT seq, hash FROM audit_log ORDER BY seq DESC LIMIT 1").fetchone()
        assets = conn.execute("SELECT sha256, size_bytes FROM assets").fetchall()
        queued = conn.execute("SELECT bundle_id, chunks FROM outbox WHERE state = 'queued'").fetchall()
    assert list(last) == [summary["audit_head"]["seq"], summary["audit_head"]["hash"]]
    assert len(assets) >= 3 and len(queued) == 1
    for sha, size in assets:
        blob = into / "burnedge-media" / "blobs" / sha[:2] / sha
        assert blob.stat().st_size == size and hashlib.sha256(blob.read_bytes()).hexdigest() == sha
    bundle, _ = queued[0]
    original = sites.folder / "burnedge-outbox" / bundle
    names = sorted(p.name for p in original.iterdir())
    assert names == ["sealed.bin"] and sorted(p.name for p in (into / "burnedge-outbox" / bundle).iterdir()) == names
    assert (into / "burnedge-outbox" / bundle / "sealed.bin").read_bytes() == (original / "sealed.bin").read_bytes()
    assert (into / "burnedge-keys" / "site.key").read_bytes() == (
        sites.folder / "burnedge-keys" / "site.key"
    ).read_bytes()
    assert (into / "burnedge-keys" / "site.key").stat().st_mode & 0o077 == 0

    proc, url = serve(config, into)
    try:
        client = GatewayClient(url)
        client.login("clin", PASSWORD)
        missing = [pid for pid in before if client.http.get(f"/api/v1/patients/{pid}").status_code != 200]
        assert missing == [], f"{len(missing)} of {len(before)} writes acknowledged before the backup are missing"
        sha = assets[0][0]
        asset = next(
            a
            for a in client.get(f"/api/v1/encounters/{_encounter(into / db.name)}/assets", "assets")
            if a["sha256"] == sha
        )
        content = client.http.get(f"/api/v1/assets/{asset['id']}/file")
        assert content.status_code == 200 and hashlib.sha256(content.content).hexdigest() == sha
    finally:
        proc.terminate()
        proc.wait(15)


def _encounter(db: Path) -> str:
    with sqlite3.connect(db) as conn:
        return conn.execute("SELECT encounter_id FROM assets LIMIT 1").fetchone()[0]


@pytest.fixture(scope="module")
def small_backup(tmp_path_factory) -> Path:
    """A backup of a gateway with an account and keys, spanning several 16 KiB chunks."""
    folder = tmp_path_factory.mktemp("small")
    db = folder / "g.sqlite3"
    cli(
        "--db",
        str(db),
        "users",
        "add",
        "--username",
        "admin",
        "--role",
        "admin",
        "--password-stdin",
        stdin=PASSWORD + "\n",
    )
    cli("--db", str(db), "keys", "init", "--site-id", "clinic-small", "--name", "Small clinic")
    r = burnedge(
        "--db",
        str(db),
        "backup",
        "--out",
        str(folder / "small.burnedge-backup"),
        "--passphrase-env",
        "BACKUP_PASSPHRASE",
    )
    assert r.returncode == 0, r.stderr
    return folder / "small.burnedge-backup"


def _chunk_start(path: Path) -> int:
    data = path.read_bytes()
    length = int.from_bytes(data[len(MAGIC) : len(MAGIC) + 4], "big")
    return len(MAGIC) + 4 + length + 32


def _damaged(small_backup: Path, tmp_path: Path, how: str) -> Path:
    data = bytearray(small_backup.read_bytes())
    start, sealed = _chunk_start(small_backup), 16 * 1024 + 17
    assert len(data) > start + 3 * sealed
    if how == "flip":
        data[len(data) // 2] ^= 0x01
    elif how == "header":
        data[len(MAGIC) + 10] ^= 0x01
    elif how == "cut-mid-chunk":
        data = data[: len(data) // 2]
    elif how == "cut-at-chunk":
        data = data[: start + 2 * sealed]
    out = tmp_path / f"{how}.burnedge-backup"
    out.write_bytes(bytes(data))
    return out


@pytest.mark.parametrize(
    "how, words",
    [
        ("flip", "damaged or was altered"),
        ("header", "header is damaged"),
        ("cut-mid-chunk", "cut short"),
        ("cut-at-chunk", "cut short"),
    ],
)
def test_a_damaged_or_cut_backup_is_refused_and_nothing_is_written(small_backup, tmp_path, how, words):
    into = tmp_path / "restored"
    r = burnedge(
        "restore",
        str(_damaged(small_backup, tmp_path, how)),
        "--into",
        str(into),
        "--passphrase-env",
        "BACKUP_PASSPHRASE",
    )
    assert r.returncode == 2 and words in r.stderr and "use another copy" in r.stderr.lower(), r.stderr
    assert not into.exists()
    empty = tmp_path / "empty"
    empty.mkdir()
    r = burnedge(
        "restore",
        str(_damaged(small_backup, tmp_path, how)),
        "--into",
        str(empty),
        "--passphrase-env",
        "BACKUP_PASSPHRASE",
    )
    assert r.returncode == 2 and list(empty.iterdir()) == []


def test_a_wrong_passphrase_is_refused(small_backup, tmp_path):
    r = burnedge(
        "restore",
        str(small_backup),
        "--into",
        str(tmp_path / "r"),
        "--passphrase-env",
        "WRONG",
        env={"WRONG": "not the passphrase at all"},
    )
    assert r.returncode == 5 and "wrong passphrase" in r.stderr and not (tmp_path / "r").exists()


def test_a_non_empty_folder_is_refused_unless_forced(small_backup, tmp_path):
    into = tmp_path / "busy"
    into.mkdir()
    (into / "something.txt").write_text("keep me")
    (into / "g.sqlite3-wal").write_bytes(b"an old database's log")
    args = ("restore", str(small_backup), "--into", str(into), "--passphrase-env", "BACKUP_PASSPHRASE")
    r = burnedge(*args)
    assert r.returncode == 4 and "not empty" in r.stderr and "--force" in r.stderr
    r = burnedge(*args, "--force")
    assert r.returncode == 0, r.stderr
    assert (into / "something.txt").read_text() == "keep me" and not (into / "g.sqlite3-wal").exists()
    assert burnedge("--config", str(into / "burnedge.toml"), "audit", "verify").returncode == 0


def test_check_only_verifies(small_backup):
    r = burnedge("restore", str(small_backup), "--check", "--passphrase-env", "BACKUP_PASSPHRASE")
    assert r.returncode == 0 and msgspec.json.decode(r.stdout)["site_id"] == "clinic-small", r.stderr


def test_recipient_key_mode_round_trips_and_refuses_another_key(tmp_path):
    db = tmp_path / "g.sqlite3"
    cli(
        "--db",
        str(db),
        "users",
        "add",
        "--username",
        "admin",
        "--role",
        "admin",
        "--password-stdin",
        stdin=PASSWORD + "\n",
    )
    offline, other = tmp_path / "usb-stick", tmp_path / "other"
    assert burnedge("backup", "keygen", "--out", str(offline)).returncode == 0
    assert burnedge("backup", "keygen", "--out", str(other)).returncode == 0
    assert (offline / "backup-recipient.key.json").stat().st_mode & 0o077 == 0
    folder = tmp_path / "backups"
    for _ in range(3):  # rotation: the newest two stay
        r = burnedge(
            "--db",
            str(db),
            "backup",
            "--dir",
            str(folder),
            "--keep",
            "2",
            "--recipient",
            str(offline / "backup-recipient.pub.json"),
        )
        assert r.returncode == 0, r.stderr
    backups = sorted(folder.glob("*.burnedge-backup"))
    assert len(backups) == 2 and not list(folder.glob("*.partial"))
    r = burnedge(
        "restore",
        str(backups[-1]),
        "--into",
        str(tmp_path / "r1"),
        "--identity",
        str(other / "backup-recipient.key.json"),
    )
    assert r.returncode == 5 and "encrypted to recipient key" in r.stderr and not (tmp_path / "r1").exists()
    r = burnedge("restore", str(backups[-1]), "--into", str(tmp_path / "r1"))
    assert r.returncode == 2 and "--identity" in r.stderr
    r = burnedge(
        "restore",
        str(backups[-1]),
        "--into",
        str(tmp_path / "r1"),
        "--identity",
        str(offline / "backup-recipient.key.json"),
    )
    assert r.returncode == 0, r.stderr
    assert burnedge("--config", str(tmp_path / "r1" / "burnedge.toml"), "audit", "verify").returncode == 0


def test_a_passphrase_is_never_taken_from_nowhere(tmp_path):
    db = tmp_path / "g.sqlite3"
    Database(db).migrate()
    r = subprocess.run(
        [sys.executable, "-m", "burnedge.cli", "--db", str(db), "backup", "--out", str(tmp_path / "b")],
        capture_output=True,
        text=True,
        cwd=REPO,
        stdin=subprocess.DEVNULL,
    )
    assert r.returncode == 2 and "--passphrase-file" in r.stderr and not (tmp_path / "b").exists()


def test_the_snapshot_takes_finished_analyses_without_scratch_and_leaves_running_ones(tmp_path):
    config = Config(gateway=GatewayConfig(database=str(tmp_path / "g.sqlite3")))
    db = Database(config.gateway.database)
    db.migrate()
    work = tmp_path / "burnedge-analyses"
    patient = uuid7()
    for job, state in ((uuid7(), "done"), (uuid7(), "running")):
        with db.write() as conn:
            conn.execute(
                "INSERT INTO analysis_jobs (id, encounter_id, patient_id, input_digest, request, state,"
                " priority, max_attempts, next_attempt_at, pictures, created_at, created_by, user_id)"
                " VALUES (?, ?, ?, ?, '{}', ?, 0, 3, '', 6, '', 'clin', 'u')",
                (job, uuid7(), patient, job, state),
            )
        for rel in ("analysis/analysis.json", "analysis/mesh/surface.ply", "source/a.jpg", "analysis/dense/d.bin"):
            (work / job / rel).parent.mkdir(parents=True, exist_ok=True)
            (work / job / rel).write_text(rel)
        if state == "done":
            done = job
    (work / "patients" / patient).mkdir(parents=True)
    (work / "patients" / patient / "track.json").write_text("{}")
    db.close()
    stale = tmp_path / ".burnedge-backup-killed"  # left by a backup that was killed: a plain database copy
    stale.mkdir()
    (stale / "g.sqlite3").write_bytes(b"copy")
    with snapshot.take(config) as snap:
        assert not stale.exists()
        names = sorted(name for name, _ in snap.files)
    assert names == [
        f"analyses/{done}/analysis/analysis.json",
        f"analyses/{done}/analysis/mesh/surface.ply",
        f"analyses/patients/{patient}/track.json",
    ]
    assert not list(tmp_path.glob(".burnedge-backup-*")), "the staged database copy is removed"
