"""The burn center under many clinics, on loopback: cases per minute, time from queued to receipt, throughput next to
a raw Zenoh put, and the center's peak memory for one large case.

    .venv/bin/python -m benchmarks.center_load [--clinics 200] [--cases 3] [--min-mb 1] [--max-mb 5]

Simulated clinics (harness/sim_clinics.py: real gateway databases, keys, outbox and sync rounds, each its own Zenoh
session) in 4 processes of 8 sending threads queue every case first, then all send at once, to:
- 1 worker on SQLite, its own router (the baseline);
- 1 worker on PostgreSQL behind `burnedge central router`;
- 2 workers on PostgreSQL behind it, worker 0 SIGKILLed after a third of the cases and restarted.
Every configuration must store every case once (checked). Same run: a raw Zenoh put of 5 MB payloads from a
client session through a router to a subscriber (shared memory off), and one clinic sending a single 200 MB case
to a 1-worker center whose peak resident memory (VmHWM) is read next to that of one that received a 2 MB case.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import platform
import tempfile
import threading
import time
from pathlib import Path

import zenoh

from center.app import open_center_db
from harness.center_load import LoadCenter, run_load
from harness.postgres import PostgresServer
from harness.processes import free_port


def raw_put_mb_s(payload_mb: int = 5, count: int = 20) -> float:
    def conf(mode: str, key: str, endpoint: str) -> zenoh.Config:
        c = zenoh.Config()
        c.insert_json5("mode", json.dumps(mode))
        c.insert_json5(key, json.dumps([endpoint]))
        c.insert_json5("scouting/multicast/enabled", "false")
        c.insert_json5("transport/shared_memory/enabled", "false")
        return c

    endpoint = f"tcp/127.0.0.1:{free_port()}"
    payload = os.urandom(payload_mb * 1_000_000)
    got = threading.Semaphore(0)
    with zenoh.open(conf("router", "listen/endpoints", endpoint)) as router:
        sub = router.declare_subscriber("bench/raw", lambda sample: got.release())
        with zenoh.open(conf("client", "connect/endpoints", endpoint)) as client:
            time.sleep(0.5)
            publisher = client.declare_publisher("bench/raw", congestion_control=zenoh.CongestionControl.BLOCK)
            publisher.put(payload)
            got.acquire(timeout=30)
            start = time.perf_counter()
            for _ in range(count):
                publisher.put(payload)
            for _ in range(count):
                got.acquire(timeout=60)
            seconds = time.perf_counter() - start
            publisher.undeclare()
        sub.undeclare()
    return payload_mb * count / seconds


def peak_memory_mib(work: Path, case_mb: float) -> float:
    """The center worker's VmHWM after one clinic sent one case of `case_mb`."""
    center = LoadCenter(work, None, workers=1)
    try:
        run = run_load(
            center,
            work / "clinics",
            clinics=1,
            cases=1,
            min_mb=case_mb,
            max_mb=case_mb,
            processes=1,
            threads=1,
            timeout_s=900,
        )
        if run.undelivered:
            raise RuntimeError("the large case was not delivered")
        status = Path(f"/proc/{center.workers[0].proc.pid}/status").read_text()
        return int(next(line for line in status.splitlines() if line.startswith("VmHWM")).split()[1]) / 1024
    finally:
        center.stop()


def stored_once(center: LoadCenter, expected: int) -> bool:
    db = open_center_db(center.central)
    try:
        rows = db.connection().execute("SELECT COUNT(*), COUNT(DISTINCT bundle_id) FROM bundles").fetchone()
        return rows[0] == rows[1] == expected
    finally:
        db.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--clinics", type=int, default=200)
    parser.add_argument("--cases", type=int, default=3)
    parser.add_argument("--min-mb", type=float, default=1.0)
    parser.add_argument("--max-mb", type=float, default=5.0)
    parser.add_argument("--processes", type=int, default=4)
    parser.add_argument("--threads", type=int, default=8)
    parser.add_argument("--large-mb", type=float, default=200.0)
    parser.add_argument("--json", help="also write the figures here")
    args = parser.parse_args()
    results: dict = {"raw Zenoh put MB/s": round(raw_put_mb_s(), 1)}
    with tempfile.TemporaryDirectory() as tmp:
        server = PostgresServer().start()
        try:
            for name, database, workers, kill in (
                ("1 worker, SQLite", None, 1, False),
                ("1 worker, PostgreSQL", server.create_database("load1"), 1, False),
                ("2 workers, PostgreSQL, one killed", server.create_database("load2"), 2, True),
            ):
                work = Path(tmp) / name.split(",")[0].replace(" ", "-") / str(bool(database))
                center = LoadCenter(work / "center", database, workers)
                total = args.clinics * args.cases
                try:
                    run = run_load(
                        center,
                        work / "clinics",
                        clinics=args.clinics,
                        cases=args.cases,
                        min_mb=args.min_mb,
                        max_mb=args.max_mb,
                        processes=args.processes,
                        threads=args.threads,
                        kill_after=total // 3 if kill else None,
                        timeout_s=1800,
                    )
                finally:
                    center.stop()
                results[name] = {**run.figures(), "stored once": stored_once(center, total)}
                print(name, results[name], flush=True)
                if run.undelivered or not results[name]["stored once"]:
                    raise RuntimeError(f"{name}: not every case was stored exactly once: {results[name]}")
        finally:
            server.stop()
        results["center peak MiB, 2 MB case"] = round(peak_memory_mib(Path(tmp) / "small", 2), 1)
        results[f"center peak MiB, {args.large_mb:g} MB case"] = round(
            peak_memory_mib(Path(tmp) / "large", args.large_mb), 1
        )
    figures = {
        "date": dt.date.today().isoformat(),
        "machine": f"{platform.machine()}, {os.cpu_count()} cores",
        "clinics": args.clinics,
        "cases": args.cases,
        "mb": [args.min_mb, args.max_mb],
        "results": results,
    }
    print(json.dumps(figures, indent=2))
    if args.json:
        Path(args.json).write_text(json.dumps(figures, indent=2))


if __name__ == "__main__":
    main()
