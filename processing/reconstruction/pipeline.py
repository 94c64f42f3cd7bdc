"""The reconstruction pipeline: wires the stages' artifacts together in one analysis folder.

    OUT/inputs.json, OUT/images/        stage 0: usable pictures
    OUT/sfm/model/, sfm_quality.json    stage 1: Structure from Motion (COLMAP model + database)
    OUT/scale/scale.json                stage 2: metric scale and output frame
    OUT/dense/fused_points.ply          stage 3a: multi-view stereo
    OUT/mesh/surface.ply, surface.glb   stage 3b: surface mesh
    OUT/report.json                     the outcome

A stage whose artifact exists is skipped, so an interrupted analysis resumes at the first
unfinished stage; once a stage runs, every later stage runs again.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from importlib import metadata
from pathlib import Path

from processing.reconstruction import dense, inputs, mesh, scale, sfm
from processing.reconstruction.artifacts import read_json, write_json
from schemas.config import Config
from schemas.errors import CaptureInsufficient
from schemas.reconstruction import (
    DenseQuality,
    FailureCode,
    InputSet,
    Outcome,
    ReconstructionReport,
    RulerPoints,
    ScaleResult,
    SfmQuality,
    StageTiming,
)

log = logging.getLogger(__name__)

REPORT = "report.json"


def paths(out: Path) -> dict[str, Path]:
    return {
        "inputs": out / inputs.RECORD,
        "images": out / inputs.IMAGES,
        "sfm_model": out / "sfm" / sfm.MODEL,
        "sfm_quality": out / "sfm" / sfm.QUALITY,
        "scale": out / "scale" / scale.RESULT,
        "dense_points": out / "dense" / dense.POINTS,
        "dense_info": out / "dense" / dense.INFO,
        "mesh_ply": out / "mesh" / mesh.PLY,
        "mesh_glb": out / "mesh" / mesh.GLB,
        "mesh_quality": out / "mesh" / mesh.QUALITY,
    }


def run(config: Config, source: Path, out: Path, ruler: RulerPoints | None = None, *,
        gate: bool = True) -> ReconstructionReport:  # fmt: skip
    """Run (or resume) every stage; the report is also written to OUT/report.json."""
    conf = config.reconstruction
    p = paths(out)
    for folder in ("sfm", "scale", "dense", "mesh"):
        (out / folder).mkdir(parents=True, exist_ok=True)
    timings: list[StageTiming] = []
    rerun = False

    def stage(name: str, done: Path, work: Callable[[], object]) -> None:
        nonlocal rerun
        if done.exists() and not rerun:
            timings.append(StageTiming(stage=name, seconds=0.0, resumed=True))
            return
        rerun = True
        start = time.perf_counter()
        work()
        timings.append(StageTiming(stage=name, seconds=round(time.perf_counter() - start, 2)))
        log.info("stage %s done in %.1f s", name, timings[-1].seconds)

    pictures: list[str] = []
    try:
        stage("inputs", p["inputs"], lambda: inputs.run(config, source, out, gate=gate))
        record = read_json(p["inputs"], InputSet)
        pictures = record.pictures
        stage("sfm", p["sfm_quality"],
              lambda: sfm.run(conf, p["images"], record.pictures, out / "sfm", video=record.video))  # fmt: skip
        stage("scale", p["scale"], lambda: scale.run(conf, p["sfm_model"], p["images"], out / "scale", ruler))
        stage("dense", p["dense_info"], lambda: dense.run(conf, p["sfm_model"], p["images"], p["scale"], out / "dense"))
        stage("mesh", p["mesh_quality"], lambda: mesh.run(conf, out / "dense", out / "mesh"))
    except CaptureInsufficient as exc:
        report = ReconstructionReport(
            outcome=Outcome.failed, reason=exc.detail, failure=FailureCode(exc.code), pictures=pictures,
            sfm=_maybe(p["sfm_quality"], SfmQuality), scale=_scale(p["scale"]), timings=timings,
            software=software_versions(),
        )  # fmt: skip
        write_json(out / REPORT, report)
        return report
    report = ReconstructionReport(
        outcome=Outcome.complete, pictures=pictures, sfm=read_json(p["sfm_quality"], SfmQuality),
        scale=_scale(p["scale"]), dense=read_json(p["mesh_quality"], DenseQuality),
        artifacts={k: str(v.relative_to(out)) for k, v in p.items() if v.exists()}, timings=timings,
        software=software_versions(),
    )  # fmt: skip
    write_json(out / REPORT, report)
    return report


def _maybe(path: Path, kind: type):
    return read_json(path, kind) if path.exists() else None


def _scale(path: Path):
    return read_json(path, ScaleResult).estimate if path.exists() else None


def software_versions() -> dict[str, str]:
    versions = {}
    for package in ("burnedge", "pycolmap", "open3d", "opencv-python-headless", "numpy", "scipy", "trimesh"):
        try:
            versions[package] = metadata.version(package)
        except metadata.PackageNotFoundError:
            continue
    return versions
