"""Many simulated clinics (harness/sim_clinics.py, spread over a few processes) sending cases to a burn center on
loopback: one `burnedge central` on SQLite, or a router with one or more workers on PostgreSQL, optionally with a
worker SIGKILLed mid-run and restarted. For the load test and the center's throughput benchmark."""

from __future__ import annotations

import json
import statistics
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

from center.app import open_center_db
from harness.processes import REPO, free_port
from harness.sim_clinics import SimClinic
from harness.sites import CENTER, CenterProcess, RouterProcess, cli
from schemas.config import CentralConfig
from sync import peers
from sync.keys import load_keys


@dataclass
class LoadRun:
    delivered: list[dict] = field(default_factory=list)
    """One line per case the clinics got a receipt for: clinic, bundle_id, bytes, seconds (queued to receipt)."""
    undelivered: int = 0
    wall_s: float = 0.0
    """From the moment every clinic had queued its cases to the last receipt."""
    killed_at: int | None = None
    """How many cases had been delivered when a worker was killed."""
    restarted_at: int | None = None
    """How many cases had been delivered when the killed worker answered again."""

    def figures(self) -> dict:
        seconds = sorted(d["seconds"] for d in self.delivered)
        total = sum(d["bytes"] for d in self.delivered)
        return {
            "cases": len(self.delivered),
            "undelivered": self.undelivered,
            "wall_s": round(self.wall_s, 1),
            "cases_per_min": round(len(self.delivered) / self.wall_s * 60, 1) if self.wall_s else 0,
            "mb_per_s": round(total / 1e6 / self.wall_s, 2) if self.wall_s else 0,
            "p50_s": round(statistics.median(seconds), 2) if seconds else None,
            "p99_s": round(seconds[max(0, int(0.99 * len(seconds)) - 1)], 2) if seconds else None,
            "killed_after": self.killed_at,
            "restarted_after": self.restarted_at,
        }


class LoadCenter:
    """The center side: `workers` processes behind a router (PostgreSQL), or one that is its own router."""

    def __init__(self, folder: Path, database: str | None, workers: int):
        self.folder = folder
        self.router = RouterProcess(folder) if workers > 1 or database else None
        port = self.router.port if self.router else free_port()
        self.endpoint = f"tcp/127.0.0.1:{port}"
        self.workers = [
            CenterProcess(folder, port, free_port(), database, name=f"center-{i}") for i in range(max(1, workers))
        ]
        for i, worker in enumerate(self.workers):
            if self.router:
                worker.env["BURNEDGE_CENTRAL_ROUTER_ENDPOINTS"] = self.router.endpoint
            worker.env["BURNEDGE_CENTRAL_WORKER_ID"] = f"w{i}"
        env = self.workers[0].env
        self.central = CentralConfig(
            database=env["BURNEDGE_CENTRAL_DATABASE"],
            store_dir=env["BURNEDGE_CENTRAL_STORE_DIR"],
            keys_dir=env["BURNEDGE_CENTRAL_KEYS_DIR"],
        )
        cli("keys", "init", "--center", "--site-id", CENTER, "--name", "Load-test center", env=env)

    def enrol(self, clinics: list[SimClinic]) -> None:
        center = load_keys(Path(self.central.keys_dir)).identity
        db = open_center_db(self.central)
        try:
            for clinic in clinics:
                peers.enrol(db, clinic.set_up(center), by="load-test")
        finally:
            db.close()

    def start(self) -> None:
        if self.router:
            self.router.start()
        for worker in self.workers:
            worker.start(timeout=60)

    def stop(self) -> None:
        for worker in self.workers:
            worker.stop()
        if self.router:
            self.router.stop()


def run_load(
    center: LoadCenter,
    folder: Path,
    *,
    clinics: int,
    cases: int,
    min_mb: float,
    max_mb: float,
    processes: int,
    threads: int,
    kill_after: int | None = None,
    timeout_s: float = 900,
) -> LoadRun:
    """Set the clinics up, start the center, send every case; SIGKILL worker 0 after `kill_after` deliveries."""
    made = [SimClinic(folder, i, center.endpoint) for i in range(clinics)]
    center.enrol(made)
    for clinic in made:
        clinic.close()
    center.start()
    run = LoadRun()
    per = -(-clinics // processes)
    commands = [
        [sys.executable, "-m", "harness.sim_clinics", "--folder", str(folder), "--first", str(first)]
        + ["--count", str(min(per, clinics - first)), "--cases", str(cases), "--endpoint", center.endpoint]
        + ["--min-mb", str(min_mb), "--max-mb", str(max_mb), "--threads", str(threads), "--timeout-s", str(timeout_s)]
        for first in range(0, clinics, per)
    ]
    go = folder / "go"
    go.unlink(missing_ok=True)
    commands = [[*c, "--go-file", str(go)] for c in commands]
    lock = threading.Lock()
    queued = threading.Semaphore(0)
    procs = [subprocess.Popen(c, cwd=REPO, stdout=subprocess.PIPE, text=True) for c in commands]

    def read(proc: subprocess.Popen) -> None:
        for line in proc.stdout:
            message = json.loads(line)
            with lock:
                if "queued" in message:
                    queued.release()
                    continue
                if "undelivered" in message:
                    run.undelivered += message["undelivered"]
                    continue
                run.delivered.append(message)
                if kill_after is not None and run.killed_at is None and len(run.delivered) >= kill_after:
                    run.killed_at = len(run.delivered)
                    center.workers[0].kill()
                    restart.start()

    def restart_worker() -> None:
        center.workers[0].start(timeout=60)
        with lock:
            run.restarted_at = len(run.delivered)

    restart = threading.Thread(target=restart_worker)
    readers = [threading.Thread(target=read, args=(p,)) for p in procs]
    for reader in readers:
        reader.start()
    for _ in procs:
        queued.acquire(timeout=timeout_s)
    started = time.monotonic()
    go.touch()
    for proc, reader in zip(procs, readers, strict=True):
        proc.wait(timeout_s + 120)
        reader.join()
    run.wall_s = time.monotonic() - started
    if restart.ident is not None:
        restart.join()
    return run
