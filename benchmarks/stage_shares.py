"""Each analysis stage's share of a 12-view analysis, next to structure from motion (the same run).

    .venv/bin/python -m benchmarks.stage_shares [--phantom p3_thigh] [--profile]

`burnedge analyze` on the independent thigh phantom (../shared/phantoms/p3_thigh: 12 views, 1920 x 1440) with
its true masks given as a clinician's, from an empty folder. Prints each stage's seconds, its share of the whole
and its ratio to SfM (ratios hold on a shared, noisy machine; absolute times do not). With --profile, the metrics
stage is run once more under cProfile and its ten costliest calls are printed.
"""

from __future__ import annotations

import argparse
import cProfile
import datetime as dt
import io
import os
import platform
import pstats
import tempfile
import time
from pathlib import Path

import msgspec

from processing.analysis import measure, surface_map
from processing.analysis.pipeline import run as analyze
from processing.reconstruction import pipeline as reconstruction
from processing.reconstruction.dense import DenseInfo
from processing.stages import read_json
from schemas.config import Config

SHARED = Path(__file__).resolve().parents[2] / "shared" / "phantoms"


def profile_metrics(config: Config, out: Path, mm_per_unit: float | None) -> str:
    paths = reconstruction.paths(out)
    dense = read_json(paths["dense_info"], DenseInfo)
    views = surface_map.output_views(paths["sfm_model"], paths["scale"])
    profiler = cProfile.Profile()
    with tempfile.TemporaryDirectory() as tmp:
        profiler.runcall(
            measure.run,
            config.analysis,
            out / "surface" / surface_map.ARRAYS,
            mm_per_unit,
            dense.units_per_mm,
            views,
            Path(tmp),
        )
    text = io.StringIO()
    pstats.Stats(profiler, stream=text).sort_stats("cumulative").print_stats(10)
    return text.getvalue()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--phantom", default="p3_thigh")
    parser.add_argument("--profile", action="store_true", help="profile the metrics stage once more")
    args = parser.parse_args()
    phantom = SHARED / args.phantom
    config = Config()
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "analysis"
        started = time.perf_counter()
        result = analyze(config, phantom / "images", out, masks=phantom / "masks")
        wall = time.perf_counter() - started
        print(
            f"{dt.date.today()}, {platform.machine()}, {os.cpu_count()} cores; {args.phantom}: {result.status.value},"
            f" area {result.metrics.area_cm2} cm2, {wall:.1f} s wall"
        )
        total = sum(result.timings_s.values())
        sfm = result.timings_s.get("sfm") or float("nan")
        print("| stage | seconds | share | x SfM |")
        print("|---|---|---|---|")
        for stage, seconds in result.timings_s.items():
            print(f"| {stage} | {seconds:.2f} | {100 * seconds / total:.1f} % | {seconds / sfm:.2f} |")
        if args.profile:
            print(profile_metrics(config, out, result.scale.mm_per_unit if result.scale else None))
        print(msgspec.json.encode(result.timings_s).decode())


if __name__ == "__main__":
    main()
