"""Gateway throughput and latency over loopback, next to a bare Litestar endpoint in the same run.

    .venv/bin/python -m benchmarks.gateway_load [--seconds 8] [--connections 16] [--json out.json]

Both servers run under uvicorn (one process each) with the same settings; the load
generator runs in this process. Figures are only comparable within one run: the
ratios hold on a shared, noisy machine, the absolute numbers do not.
Goal (issue 2): record reads at >= 50 % of the bare endpoint's throughput.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import httpx

from benchmarks.http_load import LoadResult, request, run_load
from schemas.ids import uuid7

REPO = Path(__file__).resolve().parents[1]
PASSWORD = "benchmark password"


def _free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _start(args: list[str], port: int) -> subprocess.Popen:
    proc = subprocess.Popen([sys.executable, *args], cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        try:
            httpx.get(f"http://127.0.0.1:{port}/health" if "burnedge.cli" in args else f"http://127.0.0.1:{port}/bare")
            return proc
        except httpx.HTTPError as exc:
            if proc.poll() is not None:
                raise RuntimeError(proc.stderr.read().decode()) from exc
            time.sleep(0.2)
    raise RuntimeError(f"server {args} did not start")


def _seed(port: int, connections: int) -> tuple[dict[str, str], list[str]]:
    base = f"http://127.0.0.1:{port}"
    token = httpx.post(base + "/api/v1/auth/login", json={"username": "bench", "password": PASSWORD}).json()
    headers = {"Authorization": f"Bearer {token['access_token']}"}
    ids = []
    for i in range(connections):
        pid = uuid7()
        body = {
            "id": pid,
            "given_name": f"Bench{i}",
            "family_name": "Load",
            "date_of_birth": "1980-05-05",
            "sex": "female",
            "weight_kg": 60.0,
            "height_cm": 160.0,
        }
        assert httpx.post(base + "/api/v1/patients", json=body, headers=headers).status_code == 201
        ids.append(pid)
    return headers, ids


def _reads(headers: dict[str, str], ids: list[str]):
    def make(i: int, state: dict) -> bytes:
        return request("GET", f"/api/v1/patients/{ids[i]}", headers)

    return make, None


def _writes(headers: dict[str, str], ids: list[str]):
    def make(i: int, state: dict) -> bytes:
        state["weight"] = 61.0 if state.get("weight") == 60.0 else 60.0
        body = json.dumps(
            {
                "id": ids[i],
                "given_name": f"Bench{i}",
                "family_name": "Load",
                "date_of_birth": "1980-05-05",
                "sex": "female",
                "weight_kg": state["weight"],
                "height_cm": 160.0,
            }
        ).encode()
        h = {**headers, "Content-Type": "application/json", "If-Match": f'"{state.get("version", 1)}"'}
        return request("PUT", f"/api/v1/patients/{ids[i]}", h, body)

    def check(i, state, status, headers, body) -> bool:
        if "etag" in headers:
            state["version"] = int(headers["etag"].strip('W/"'))
        return status == 200

    return make, check


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=8.0)
    parser.add_argument("--connections", type=int, default=16)
    parser.add_argument("--json", help="also write the figures here")
    args = parser.parse_args(argv)

    with tempfile.TemporaryDirectory() as tmp:
        db = Path(tmp) / "bench.sqlite3"
        subprocess.run(
            [
                sys.executable,
                "-m",
                "burnedge.cli",
                "--db",
                str(db),
                "users",
                "add",
                "--username",
                "bench",
                "--role",
                "clinician",
                "--password-stdin",
            ],
            input=PASSWORD + "\n",
            text=True,
            check=True,
            cwd=REPO,
            capture_output=True,
        )
        gw_port, bare_port = _free_port(), _free_port()
        gateway = _start(["-m", "burnedge.cli", "--db", str(db), "serve", "--port", str(gw_port)], gw_port)
        bare = _start(["-m", "benchmarks.bare_app", str(bare_port)], bare_port)
        try:
            headers, ids = _seed(gw_port, args.connections)
            opts = {"connections": args.connections, "seconds": args.seconds}
            bare_make = lambda i, s: request("GET", "/bare")  # noqa: E731
            results: dict[str, LoadResult] = {}
            results["bare (before)"] = run_load(bare_port, bare_make, **opts)
            results["record read"] = run_load(gw_port, *_reads(headers, ids), **opts)
            results["record write"] = run_load(gw_port, *_writes(headers, ids), **opts)
            results["bare (after)"] = run_load(bare_port, bare_make, **opts)
        finally:
            for proc in (gateway, bare):
                proc.terminate()
                proc.wait(10)

    bare_rps = (results["bare (before)"].rps + results["bare (after)"].rps) / 2
    report = {
        "date": dt.date.today().isoformat(),
        "machine": f"{platform.machine()}, {os.cpu_count()} cores, {platform.system()} {platform.release()}",
        "python": platform.python_version(),
        "connections": args.connections,
        "seconds": args.seconds,
        "results": {name: r.row() for name, r in results.items()},
        "read_vs_bare": round(results["record read"].rps / bare_rps, 3),
        "write_vs_bare": round(results["record write"].rps / bare_rps, 3),
    }
    _print(report)
    if args.json:
        Path(args.json).write_text(json.dumps(report, indent=2) + "\n")
    return report


def _print(report: dict) -> None:
    print(
        f"gateway load, {report['date']}, {report['machine']}, Python {report['python']}, "
        f"{report['connections']} connections x {report['seconds']} s"
    )
    print(f"{'workload':<15}{'req/s':>10}{'p50 ms':>10}{'p99 ms':>10}{'errors':>8}")
    for name, row in report["results"].items():
        print(f"{name:<15}{row['rps']:>10.1f}{row['p50_ms']:>10.2f}{row['p99_ms']:>10.2f}{row['errors']:>8}")
    print(
        f"read throughput / bare: {report['read_vs_bare']:.2f} (goal >= 0.50); "
        f"write / bare: {report['write_vs_bare']:.2f}"
    )


if __name__ == "__main__":
    main()
