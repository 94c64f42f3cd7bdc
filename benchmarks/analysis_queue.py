"""The analysis queue on the gateway: API latency while an analysis runs, and request-to-stored time.

    .venv/bin/python -m benchmarks.analysis_queue [--seconds 10] [--connections 4] [--json out.json]

Same run, same machine:
- API p50/p99 of record reads with no analysis running (baseline) and while the worker reconstructs;
- end-to-end time from "analysis requested" (POST) to "results stored" (job done, record written) for a
  12-view set through the real gateway, next to `burnedge analyze` on the same photos run directly.
Goal (issue 6): the API stays responsive while an analysis runs (the worker runs niced).
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

from benchmarks.http_load import request, run_load
from burnedge.demo_client import GatewayClient
from harness.bodies import encounter_body
from harness.bodies import patient_body as patient
from harness.processes import FAST_HASH_ENV, GatewayProcess, add_user_cli, free_port, login

REPO = Path(__file__).resolve().parents[1]
SHARED_SET = REPO.parent / "shared" / "phantoms" / "p3_thigh"


def photos(work: Path) -> Path:
    """A 12-view set: the independent generator's thigh phantom when ../shared is there, else one rendered."""
    if (SHARED_SET / "images").is_dir():
        return SHARED_SET
    out = work / "phantom"
    subprocess.run(
        [sys.executable, "-m", "burnedge.cli", "phantom", "--out", str(out), "--views", "12", "--seed", "21"],
        check=True,
        cwd=REPO,
        capture_output=True,
    )
    return out


def direct(images: Path, out: Path) -> float:
    start = time.perf_counter()
    subprocess.run(
        [sys.executable, "-m", "burnedge.cli", "analyze", str(images), "--out", str(out)],
        check=True,
        cwd=REPO,
        capture_output=True,
        env={**os.environ, **FAST_HASH_ENV},
    )
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seconds", type=float, default=10.0, help="length of each latency measurement")
    parser.add_argument("--connections", type=int, default=4, help="concurrent keep-alive clients")
    parser.add_argument("--json", help="also write the figures here")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        scene = photos(work)
        baseline_s = direct(scene / "images", work / "direct")
        gw = GatewayProcess(work / "gw.sqlite3", free_port())
        add_user_cli(gw.db, "bench", "clinician")
        gw.start()
        phone = GatewayClient(gw.url)
        try:
            phone.http.headers.update(login(phone.http, "bench"))
            p = patient()
            phone.post("/api/v1/patients", p, "patient")
            e = encounter_body(p["id"])
            phone.post("/api/v1/encounters", e, "encounter")
            for f in sorted((scene / "images").glob("*.jpg")):
                phone.upload(f, e["id"])
            read = request(
                "GET", f"/api/v1/encounters/{e['id']}/record", {"Authorization": phone.http.headers["Authorization"]}
            )

            def load():
                return run_load(
                    gw.port, lambda i, s: read, connections=args.connections, seconds=args.seconds, warmup=1.0
                ).row()

            idle = load()
            requested = time.perf_counter()
            job = phone.post(f"/api/v1/encounters/{e['id']}/analyses", {}, "request")
            while phone.get(f"/api/v1/analyses/{job['id']}", "poll")["stage"] not in ("sfm", "dense"):
                time.sleep(0.2)
            busy = load()
            last = phone.follow(job["id"], lambda ev: None)
            queued_s = time.perf_counter() - requested
            result = phone.get(f"/api/v1/analyses/{job['id']}/result", "result")
        finally:
            phone.close()
            gw.stop()
    figures = {
        "date": dt.date.today().isoformat(),
        "machine": f"{platform.machine()}, {os.cpu_count()} cores",
        "scene": scene.name,
        "views": len(list((scene / "images").glob("*.jpg"))),
        "api_idle": idle,
        "api_during_analysis": busy,
        "p99_ratio_during_vs_idle": round(busy["p99_ms"] / idle["p99_ms"], 2),
        "end_to_end_s": round(queued_s, 1),
        "direct_analyze_s": round(baseline_s, 1),
        "end_to_end_vs_direct": round(queued_s / baseline_s, 2),
        "job_state": last["state"],
        "area_cm2": result["metrics"]["area_cm2"],
    }
    print(f"{'':<28}{'requests/s':>12}{'p50 ms':>10}{'p99 ms':>10}")
    for name, row in (("API, no analysis (baseline)", idle), ("API, analysis running", busy)):
        print(f"{name:<28}{row['rps']:>12.1f}{row['p50_ms']:>10.2f}{row['p99_ms']:>10.2f}")
    print(f"p99 during / idle: {figures['p99_ratio_during_vs_idle']}")
    print(
        f"requested -> stored through the gateway: {queued_s:.1f} s; `burnedge analyze` directly: {baseline_s:.1f} s"
        f" (ratio {figures['end_to_end_vs_direct']})"
    )
    if args.json:
        Path(args.json).write_text(json.dumps(figures, indent=2) + "\n")


if __name__ == "__main__":
    main()
