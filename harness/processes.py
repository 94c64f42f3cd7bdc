"""The gateway as a real process on loopback, and what starting one takes: a free port, cheap password hashing,
accounts added with the command line, a login."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import httpx

REPO = Path(__file__).resolve().parents[1]
PASSWORD = "correct horse battery"

FAST_HASH_ENV = {
    "BURNEDGE_SECURITY_ARGON2_MEMORY_KIB": "8",
    "BURNEDGE_SECURITY_ARGON2_TIME_COST": "1",
    "BURNEDGE_SECURITY_ARGON2_PARALLELISM": "1",
}
"""Argon2 at its cheapest, for processes started here: they exercise the logic, the benchmark measures the cost."""


def login(client, username: str, device_token: str | None = None) -> dict[str, str]:
    headers = {"X-Device-Token": device_token} if device_token else {}
    r = client.post("/api/v1/auth/login", json={"username": username, "password": PASSWORD}, headers=headers)
    assert r.status_code == 200, r.text
    return {"Authorization": f"Bearer {r.json()['access_token']}"}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


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
