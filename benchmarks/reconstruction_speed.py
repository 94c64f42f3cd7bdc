"""Photos to scaled mesh, stage by stage, next to pycolmap's sparse reconstruction alone, in the same run.

    .venv/bin/python -m benchmarks.reconstruction_speed [--phantom DIR] [--runs 1]

Goal (issue 4): a 12-view 1920 x 1440 set from photos to scaled mesh in <= 120 s on the clinic
machine (2 cores), peak memory below 4 GB. The baseline is pycolmap with COLMAP's default SIFT
and mapper options (exhaustive matching, incremental mapping) on the same pictures: what
"just run COLMAP" costs. Each run is a fresh child process, so its peak RSS is its own.
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

REPO = Path(__file__).resolve().parents[1]

_BASELINE = """
import sys, time, pycolmap
from pathlib import Path
images, out = Path(sys.argv[1]), Path(sys.argv[2])
out.mkdir(parents=True, exist_ok=True)
t = time.perf_counter()
pycolmap.extract_features(out / "db.db", images, camera_mode=pycolmap.CameraMode.SINGLE, device=pycolmap.Device.cpu)
pycolmap.match_exhaustive(out / "db.db", device=pycolmap.Device.cpu)
models = pycolmap.incremental_mapping(out / "db.db", images, out)
best = max(models.values(), key=lambda m: m.num_reg_images())
print(time.perf_counter() - t, best.num_reg_images())
"""


def _child(args: list[str]) -> tuple[float, int, str]:
    """Wall seconds, peak RSS (MB) and stdout of a child process (wait4 gives that child's own peak)."""
    t = time.perf_counter()
    process = subprocess.Popen(args, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    stdout = process.stdout.read()
    _, status, usage = os.wait4(process.pid, 0)
    process.returncode = os.waitstatus_to_exitcode(status)
    wall = time.perf_counter() - t
    if process.returncode != 0:
        raise RuntimeError(f"{args[:4]} exited with {process.returncode}")
    return wall, usage.ru_maxrss // 1024, stdout


def render(out: Path) -> float:
    t = time.perf_counter()
    subprocess.run(
        [sys.executable, "-m", "burnedge.cli", "phantom", "--out", str(out), "--views", "12", "--seed", "1"],
        cwd=REPO,
        check=True,
        capture_output=True,
    )
    return time.perf_counter() - t


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--phantom", type=Path, help="an existing phantom folder (default: render one)")
    parser.add_argument("--runs", type=int, default=1)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        phantom = args.phantom
        if phantom is None:
            phantom = Path(tmp) / "phantom"
            print(f"rendered a 12-view 1920x1440 forearm phantom in {render(phantom):.1f} s (not counted)")
        images = phantom / "images"
        rows = []
        for run in range(args.runs):
            wall_b, rss_b, out_b = _child([sys.executable, "-c", _BASELINE, str(images), f"{tmp}/baseline{run}"])
            seconds_b, registered_b = out_b.split()[-2:]
            out = Path(tmp) / f"analysis{run}"
            wall, rss, out_p = _child(
                [sys.executable, "-m", "burnedge.cli", "reconstruct", str(images), "--out", str(out)]
            )
            report = json.loads(out_p)
            stages = {t["stage"]: t["seconds"] for t in report["timings"]}
            rows.append(
                {
                    "pipeline_s": round(wall, 1),
                    "stages_s": stages,
                    "pipeline_peak_mb": rss,
                    "registered": report["sfm"]["images_registered"],
                    "used": report["sfm"]["images_used"],
                    "baseline_sparse_s": round(float(seconds_b), 1),
                    "baseline_process_s": round(wall_b, 1),
                    "baseline_registered": int(registered_b),
                    "baseline_peak_mb": rss_b,
                    "ratio_pipeline_to_sparse": round(wall / wall_b, 2),
                }
            )
    print(
        json.dumps(
            {
                "date": dt.date.today().isoformat(),
                "machine": f"{platform.machine()}, {os.cpu_count()} cores",
                "goal": "pipeline <= 120 s, peak < 4096 MB",
                "runs": rows,
            },
            indent=2,
        )
    )


if __name__ == "__main__":
    main()
