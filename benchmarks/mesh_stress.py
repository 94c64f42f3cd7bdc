"""The mesh stage run again and again on the shared phantoms' dense points, counting native crashes.

    .venv/bin/python -m benchmarks.mesh_stress [--phantoms p1_forearm,p3_thigh] [--runs 100] [--threads -1,1]

Once, in the demo, the analysis process died of SIGSEGV inside Open3D's screened Poisson (meshing). Open3D's
PoissonRecon is reported to crash now and then when it runs on several threads (isl-org/Open3D #6828, #7229), so
`[reconstruction] mesh_threads` is 1. This benchmark reconstructs each phantom once (up to the dense points),
then runs `processing.reconstruction.mesh.run` `--runs` times per thread setting, in a child process that is
restarted after a crash, and prints the crashes and the time per run next to each other (same run, same points).
"""

from __future__ import annotations

import argparse
import datetime as dt
import multiprocessing
import platform
import tempfile
import time
from pathlib import Path

import msgspec

from schemas.config import Config

SHARED = Path(__file__).resolve().parents[2] / "shared" / "phantoms"


def dense_points(config: Config, phantom: Path, out: Path) -> Path:
    """The phantom's analysis folder reconstructed up to (and including) the mesh; returns its dense folder."""
    from processing.reconstruction.pipeline import run as reconstruct

    report = reconstruct(config, phantom / "images", out)
    if not (out / "dense" / "fused_points.ply").exists():
        raise RuntimeError(f"{phantom.name}: no dense points ({report.reason})")
    return out / "dense"


def _loop(config: Config, dense: str, out: str, runs: int, counter: str) -> None:
    from processing.reconstruction import mesh

    for _ in range(runs):
        started = time.perf_counter()
        mesh.run(config.reconstruction, Path(dense), Path(out))
        with open(counter, "a") as handle:
            handle.write(f"{time.perf_counter() - started:.3f}\n")


def stress(config: Config, dense: Path, runs: int, threads: int) -> tuple[int, list[float]]:
    """(crashes, seconds per finished run) for `runs` meshings with `threads` threads."""
    conf = msgspec.structs.replace(
        config, reconstruction=msgspec.structs.replace(config.reconstruction, mesh_threads=threads)
    )
    context = multiprocessing.get_context("spawn")
    crashes = 0
    with tempfile.TemporaryDirectory() as work:
        counter = Path(work) / "runs.txt"
        counter.touch()
        while len(counter.read_text().split()) < runs:
            left = runs - len(counter.read_text().split())
            child = context.Process(target=_loop, args=(conf, str(dense), work, left, str(counter)))
            child.start()
            child.join()
            if child.exitcode != 0:
                crashes += 1
                print(f"    crash (exit {child.exitcode}) after {len(counter.read_text().split())} runs", flush=True)
        return crashes, [float(t) for t in counter.read_text().split()]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--phantoms", default="p1_forearm,p3_thigh")
    parser.add_argument("--runs", type=int, default=100)
    parser.add_argument("--threads", default="-1,1", help="thread settings to compare, e.g. -1,1")
    parser.add_argument("--work", type=Path, help="keep the reconstructions here (default: a temporary folder)")
    args = parser.parse_args()
    config = Config()
    print(
        f"{dt.date.today()}, {platform.machine()}, {multiprocessing.cpu_count()} cores, Open3D "
        f"{__import__('open3d').__version__}"
    )
    print("| phantom | mesh_threads | runs | crashes | median s/run |")
    print("|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        work = args.work or Path(tmp)
        for name in args.phantoms.split(","):
            dense = dense_points(config, SHARED / name, work / name)
            for threads in (int(t) for t in args.threads.split(",")):
                crashes, times = stress(config, dense, args.runs, threads)
                median = sorted(times)[len(times) // 2] if times else float("nan")
                print(f"| {name} | {threads} | {len(times)} | {crashes} | {median:.2f} |", flush=True)


if __name__ == "__main__":
    main()
