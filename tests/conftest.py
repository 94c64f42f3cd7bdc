"""Shared fixtures: a real SQLite file per test, the real app, real accounts."""

from __future__ import annotations

import datetime as dt
import faulthandler
import os
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
from litestar.testing import TestClient

from gateway.app import create_app
from gateway.dependencies import Services
from gateway.storage.database import Database
from schemas.accounts import Role, UserCreate
from schemas.config import Config, GatewayConfig, SecurityConfig
from schemas.ids import uuid7

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"
PASSWORD = "correct horse battery"
# Argon2 at its cheapest: tests exercise the logic, the benchmark measures the real cost.
FAST_SECURITY = SecurityConfig(argon2_time_cost=1, argon2_memory_kib=8, argon2_parallelism=1)


@pytest.fixture
def config(tmp_path: Path) -> Config:
    return Config(gateway=GatewayConfig(database=str(tmp_path / "gateway.sqlite3")), security=FAST_SECURITY)


@pytest.fixture
def app(config: Config):
    return create_app(config)


@pytest.fixture
def services(app) -> Services:
    return app.state.services


@pytest.fixture
def client(app) -> Iterator[TestClient]:
    with TestClient(app) as c:
        yield c


def make_user(services: Services, username: str, role: Role) -> None:
    services.accounts.create_user(None, UserCreate(username=username, password=PASSWORD, role=role))


def login(client, username: str, device_token: str | None = None) -> dict[str, str]:
    headers = {"X-Device-Token": device_token} if device_token else {}
    r = client.post("/api/v1/auth/login", json={"username": username, "password": PASSWORD}, headers=headers)
    assert r.status_code == 200, r.text
    return {"Authorization": f"Bearer {r.json()['access_token']}"}


@pytest.fixture
def auth(client, services) -> dict[str, dict[str, str]]:
    """Authorization headers for one logged-in user of each role, keyed by role name."""
    for role in Role:
        make_user(services, role.value, role)
    return {role.value: login(client, role.value) for role in Role}


def now() -> dt.datetime:
    return dt.datetime.now(dt.UTC).replace(microsecond=0)


def patient_body(patient_id: str | None = None, **extra) -> dict:
    body = {
        "id": patient_id or uuid7(),
        "given_name": "Test",
        "family_name": "Patient",
        "date_of_birth": "1990-01-01",
        "sex": "male",
        "weight_kg": 70.0,
        "height_cm": 175.0,
    }
    body.update(extra)
    return body


def encounter_body(patient_id: str, encounter_id: str | None = None, injury_hours_ago: float = 3, **extra) -> dict:
    t = now()
    body = {
        "id": encounter_id or uuid7(),
        "patient_id": patient_id,
        "mode": "emergency",
        "time_of_injury": (t - dt.timedelta(hours=injury_hours_ago)).isoformat(),
        "time_of_arrival": (t - dt.timedelta(hours=min(injury_hours_ago, 0.5))).isoformat(),
        "clinician": "Dr. Test",
    }
    body.update(extra)
    return body


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


FAST_HASH_ENV = {
    "BURNEDGE_SECURITY_ARGON2_MEMORY_KIB": "8",
    "BURNEDGE_SECURITY_ARGON2_TIME_COST": "1",
    "BURNEDGE_SECURITY_ARGON2_PARALLELISM": "1",
}


def add_user_cli(db: Path, username: str, role: str) -> None:
    """Create an account the way an administrator would: with the command line."""
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "burnedge.cli",
            "--db",
            str(db),
            "users",
            "add",
            "--username",
            username,
            "--role",
            role,
            "--password-stdin",
        ],
        input=PASSWORD + "\n",
        capture_output=True,
        text=True,
        cwd=REPO,
        env={**FAST_HASH_ENV, "PATH": ""},
    )
    assert r.returncode == 0, r.stderr


class GatewayProcess:
    """`burnedge serve` as a real process, talking HTTP on loopback."""

    def __init__(self, db: Path, port: int):
        self.db, self.port = db, port
        self.env: dict[str, str] = {}
        """Extra BURNEDGE_* settings for the process."""
        self.url = f"http://127.0.0.1:{port}"
        self.log = db.with_suffix(".log")
        """The gateway's (and its workers') output."""
        self.proc: subprocess.Popen | None = None

    def start(self, timeout: float = 30.0) -> GatewayProcess:
        env = {**os.environ, **FAST_HASH_ENV, **self.env}
        # A file, not a pipe: a full pipe nobody reads would block the gateway and its workers on their next log line.
        with open(self.log, "ab") as log:
            self.proc = subprocess.Popen(
                [sys.executable, "-m", "burnedge.cli", "--db", str(self.db), "serve", "--port", str(self.port)],
                env=env,
                stdout=log,
                stderr=subprocess.STDOUT,
            )
        try:
            wait_healthy(self.proc, self.url, self.log, timeout, "gateway")
        except RuntimeError:
            self.stop()
            raise
        return self

    def stop(self) -> None:
        if self.proc and self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()


def wait_healthy(proc: subprocess.Popen, url: str, log: Path, timeout: float, what: str) -> None:
    """Until `url`/health answers 200; RuntimeError with the process's last output if it exits or never does."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise RuntimeError(f"{what} exited early: {log.read_text(errors='replace')[-4000:]}")
        try:
            if httpx.get(url + "/health", timeout=1).status_code == 200:
                return
        except httpx.HTTPError:
            time.sleep(0.1)
    raise RuntimeError(f"{what} did not become healthy in time")


@pytest.fixture
def gateway_process(tmp_path: Path) -> Iterator[GatewayProcess]:
    process = GatewayProcess(tmp_path / "served.sqlite3", free_port())
    yield process
    process.stop()


@pytest.fixture
def sites(tmp_path: Path):
    """A clinic gateway and a burn center set up (keys, enrolment, accounts), neither started; stopped after."""
    from tests.sync_sites import Sites

    sites = Sites(tmp_path)
    sites.set_up()
    yield sites
    sites.stop()


def open_db(path: str | Path) -> Database:
    return Database(path)


# Modules that load the big native libraries (pycolmap, Open3D, SciPy's spatial code, onnxruntime). They run
# after the gateway's threaded tests: CI once crashed (SIGSEGV, no traceback) in an upload test that ran after
# these libraries were loaded in the same process, and never when they were not. The gateway itself will run
# analyses in a separate worker process for the same reason.
NATIVE_MODULES = {
    "test_reconstruction.py",
    "test_phantom.py",
    "test_burn_surface.py",
    "test_analysis.py",
    "test_segmentation.py",
}


def pytest_collection_modifyitems(session, config, items) -> None:
    items.sort(key=lambda item: item.path.name in NATIVE_MODULES)  # stable: each group keeps its order


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item) -> None:
    # pycolmap installs glog's crash handler over Python's on import; glog writes into pytest's capture, which
    # dies with the process, so a crash would leave no trace. Put Python's handler (on the real stderr) back.
    from _pytest.faulthandler import fault_handler_stderr_fd_key

    fd = item.config.stash.get(fault_handler_stderr_fd_key, None)
    if fd is not None:
        faulthandler.disable()  # enable() alone would keep the replaced handler: it only installs once
        faulthandler.enable(file=fd, all_threads=True)
