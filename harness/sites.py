"""A clinic gateway and a burn center as real processes on loopback, set up the way an IT person would: keys made
and enrolled with the command line, accounts added, the clinic configured to connect out to the center."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import cv2
import numpy as np

from burnedge.demo_client import GatewayClient
from harness.bodies import encounter_body, patient_body
from harness.processes import FAST_HASH_ENV, PASSWORD, REPO, GatewayProcess, add_user_cli, free_port, wait_healthy

CLINIC = "clinic-test"
CENTER = "center-test"


def cli(*args: str, env: dict[str, str] | None = None, stdin: str | None = None) -> str:
    r = subprocess.run(
        [sys.executable, "-m", "burnedge.cli", *args],
        capture_output=True,
        text=True,
        cwd=REPO,
        input=stdin,
        env={**os.environ, **FAST_HASH_ENV, **(env or {})},
        timeout=120,
    )
    if r.returncode != 0:
        raise RuntimeError(f"burnedge {' '.join(args)} failed: {r.stderr}")
    return r.stdout


def noise_photo(path: Path, seed: int, size: tuple[int, int] = (1600, 1200), quality: int = 92) -> Path:
    """A photo-sized JPEG of smooth colour noise (incompressible enough to give megabytes)."""
    rng = np.random.default_rng(seed)
    small = rng.integers(0, 255, (size[1] // 2, size[0] // 2, 3), dtype=np.uint8)
    image = cv2.resize(small, size, interpolation=cv2.INTER_LINEAR)
    image = cv2.add(image, rng.integers(0, 40, image.shape, dtype=np.uint8))
    cv2.imwrite(str(path), image, [cv2.IMWRITE_JPEG_QUALITY, quality])
    return path


def record_case(
    client: GatewayClient, folder: Path, photos: int, seed: int = 0, size: tuple[int, int] = (1600, 1200)
) -> tuple[str, list[Path]]:
    """A patient, an encounter and `photos` noise photos uploaded over tus, through the clinic's HTTP API."""
    patient = client.post("/api/v1/patients", patient_body(), "patient")
    encounter_id = client.post("/api/v1/encounters", encounter_body(patient["meta"]["id"]), "encounter")["meta"]["id"]
    paths = [noise_photo(folder / f"photo-{seed}-{i}.jpg", seed * 100 + i, size=size) for i in range(photos)]
    for path in paths:
        client.upload(path, encounter_id)
    return encounter_id, paths


class CenterProcess:
    """`burnedge central` on loopback, over a SQLite file in `folder` or the PostgreSQL database `database`."""

    def __init__(
        self, folder: Path, zenoh_port: int, http_port: int, database: str | None = None, name: str = "center"
    ):
        self.folder = folder
        self.env = {
            "BURNEDGE_CENTRAL_DATABASE": database or str(folder / "center.sqlite3"),
            "BURNEDGE_CENTRAL_STORE_DIR": str(folder / "burnedge-central-store"),
            "BURNEDGE_CENTRAL_KEYS_DIR": str(folder / "burnedge-central-keys"),
            "BURNEDGE_CENTRAL_LISTEN_ENDPOINTS": f"tcp/127.0.0.1:{zenoh_port}",
            "BURNEDGE_CENTRAL_PORT": str(http_port),
        }
        self.url = f"http://127.0.0.1:{http_port}"
        self.log = folder / f"{name}.log"
        self.proc: subprocess.Popen | None = None

    def start(self, timeout: float = 30.0) -> CenterProcess:
        with open(self.log, "ab") as log:
            self.proc = subprocess.Popen(
                [sys.executable, "-m", "burnedge.cli", "central", "--site-id", CENTER, "--name", "Test burn center"],
                cwd=REPO,
                stdout=log,
                stderr=subprocess.STDOUT,
                env={**os.environ, **FAST_HASH_ENV, **self.env},
            )
        wait_healthy(self.proc, self.url, self.log, timeout, "center")
        return self

    def client(self) -> GatewayClient:
        """This center's API, signed in as the consultant `consult`."""
        client = GatewayClient(self.url)
        client.login("consult", PASSWORD)
        return client

    def rows(self, sql: str, params: tuple = ()) -> list:
        """The center database's answer to a query, read as the IT person's tools would (either backend)."""
        return query_rows(self.env["BURNEDGE_CENTRAL_DATABASE"], sql, params)

    def kill(self) -> None:
        if self.proc and self.proc.poll() is None:
            self.proc.send_signal(signal.SIGKILL)
            self.proc.wait()

    def stop(self) -> None:
        if self.proc and self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(15)
            except subprocess.TimeoutExpired:
                self.kill()


class RouterProcess:
    """`burnedge central router` on loopback: clinics and center workers connect to `endpoint`."""

    def __init__(self, folder: Path, port: int | None = None):
        self.port = port or free_port()
        self.endpoint = f"tcp/127.0.0.1:{self.port}"
        self.log = folder / "router.log"
        self.proc: subprocess.Popen | None = None

    def start(self, timeout: float = 20.0) -> RouterProcess:
        with open(self.log, "ab") as log:
            self.proc = subprocess.Popen(
                [sys.executable, "-m", "burnedge.cli", "central", "router", "--listen", self.endpoint],
                cwd=REPO,
                stdout=log,
                stderr=subprocess.STDOUT,
            )
        deadline = time.monotonic() + timeout
        while "center router listening" not in self.log.read_text():
            if self.proc.poll() is not None or time.monotonic() > deadline:
                raise AssertionError(f"the router did not start:\n{self.log.read_text()[-2000:]}")
            time.sleep(0.1)
        return self

    def stop(self) -> None:
        if self.proc and self.proc.poll() is None:
            self.proc.terminate()
            self.proc.wait(15)


class Sites:
    """Both sites' files under `folder`; neither process is started."""

    def __init__(
        self,
        folder: Path,
        *,
        center_endpoint: str | None = None,
        zenoh_port: int | None = None,
        center_database: str | None = None,
    ):
        self.folder = folder
        self.zenoh_port = zenoh_port or free_port()
        self.center = CenterProcess(folder, self.zenoh_port, free_port(), center_database)
        self.gateway = GatewayProcess(folder / "clinic.sqlite3", free_port())
        self.gateway.env.update(
            {
                "BURNEDGE_SYNC_ENABLED": "true",
                "BURNEDGE_SYNC_CENTER_ENDPOINTS": center_endpoint or f"tcp/127.0.0.1:{self.zenoh_port}",
                "BURNEDGE_SYNC_INTERVAL_S": "0.5",
                "BURNEDGE_SYNC_RETRY_BASE_S": "0.2",
                "BURNEDGE_SYNC_RETRY_MAX_S": "1",
                "BURNEDGE_SYNC_CONNECT_TIMEOUT_S": "2",
                "BURNEDGE_SYNC_QUERY_TIMEOUT_S": "20",
                "BURNEDGE_JOBS_WORKERS": "0",
            }
        )

    def set_up(self) -> None:
        db = str(self.gateway.db)
        cli("--db", db, "keys", "init", "--site-id", CLINIC, "--name", "Test field clinic")
        cli("keys", "init", "--center", "--site-id", CENTER, "--name", "Test burn center", env=self.center.env)
        keys = self.folder / "burnedge-keys" / "site.pub.json"
        center_keys = self.folder / "burnedge-central-keys" / "site.pub.json"
        cli("--db", db, "peers", "enrol", str(center_keys), "--by", "it-person")
        cli("peers", "enrol", "--center", str(keys), "--by", "it-person", env=self.center.env)
        add_user_cli(self.gateway.db, "clin", "clinician")
        cli(
            "users",
            "add",
            "--center",
            "--username",
            "consult",
            "--role",
            "consultant",
            "--name",
            "Dr Consultant",
            "--password-stdin",
            env=self.center.env,
            stdin=PASSWORD + "\n",
        )

    def clinic_client(self) -> GatewayClient:
        client = GatewayClient(self.gateway.url)
        client.login("clin", PASSWORD)
        return client

    def center_client(self) -> GatewayClient:
        return self.center.client()

    def stop(self) -> None:
        self.gateway.stop()
        self.center.stop()


def query_rows(database: str, sql: str, params: tuple = ()) -> list:
    """Rows of one query on a center database, a SQLite path or a PostgreSQL URL (`?` placeholders)."""
    from base.storage.database import Database
    from base.storage.dialect import is_postgres
    from base.storage.postgres import PostgresDatabase

    db = PostgresDatabase(database, max_connections=2) if is_postgres(database) else Database(database)
    try:
        return [tuple(row) for row in db.connection().execute(sql, params).fetchall()]
    finally:
        db.close()


def wait_for(predicate, timeout: float, what: str, every: float = 0.2):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(every)
    raise AssertionError(f"timed out after {timeout:g} s waiting for {what}")
