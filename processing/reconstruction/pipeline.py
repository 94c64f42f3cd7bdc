"""The reconstruction pipeline: wires the stages' artifacts together in one analysis folder.

    OUT/inputs.json, OUT/images/        stage 0: usable pictures
    OUT/sfm/model/, sfm_quality.json    stage 1: Structure from Motion (COLMAP model + database)
    OUT/scale/scale.json                stage 2: metric scale and output frame
    OUT/dense/fused_points.ply          stage 3a: multi-view stereo
    OUT/mesh/surface.ply, surface.glb   stage 3b: surface mesh
    OUT/report.json                     the outcome

A stage whose artifact exists, built from the same inputs, settings and ruler (fingerprints.json),
is skipped, so an interrupted analysis resumes at the first unfinished stage. A stage that runs
first removes its own and every later stage's completion artifact, so nothing stale survives it.
"""

from __future__ import annotations

import hashlib
import json
import logging
from collections.abc import Callable
from importlib import metadata
from pathlib import Path

import msgspec

from processing.reconstruction import dense, inputs, mesh, scale, sfm
from processing.stages import Stages, code_digest, read_json, write_json
from schemas.config import Config
from schemas.errors import CaptureInsufficient, NotFound
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


STAGES = ("inputs", "sfm", "scale", "dense", "mesh")
DONE = {"inputs": "inputs", "sfm": "sfm_quality", "scale": "scale", "dense": "dense_info", "mesh": "mesh_quality"}
"""The artifact each stage writes last: its presence (with a matching fingerprint) means the stage is done."""
FINGERPRINTS = "fingerprints.json"


def fingerprints(config: Config, source: Path, ruler: RulerPoints | None, gate: bool) -> dict[str, str]:
    """What each stage was built from, hashed: a changed source, setting or ruler reruns that stage and later ones."""
    files = sorted(source.iterdir()) if source.is_dir() else [source]
    listing = [(f.name, f.stat().st_size, f.stat().st_mtime_ns) for f in files if f.is_file()]
    chain: dict[str, str] = {}
    parts = {
        "inputs": [
            code_digest(),
            str(source.resolve()),
            listing,
            msgspec.to_builtins(config.quality),
            msgspec.to_builtins(config.frames),
            gate,
        ],
        "sfm": [msgspec.to_builtins(config.reconstruction)],
        "scale": [msgspec.to_builtins(ruler) if ruler else None],
        "dense": [],
        "mesh": [],
    }
    previous = ""
    for name in STAGES:
        previous = hashlib.sha256(json.dumps([previous, parts[name]], sort_keys=True).encode()).hexdigest()
        chain[name] = previous
    return chain


def run(
    config: Config,
    source: Path,
    out: Path,
    ruler: RulerPoints | None = None,
    *,
    gate: bool = True,
    progress: Callable[[str], None] | None = None,
) -> ReconstructionReport:
    """Run (or resume) every stage; the report is also written to OUT/report.json.

    `progress(stage)` is called as each stage starts (or is found finished).
    """
    conf = config.reconstruction
    p = paths(out)
    for folder in ("sfm", "scale", "dense", "mesh"):
        (out / folder).mkdir(parents=True, exist_ok=True)
    (out / REPORT).unlink(missing_ok=True)
    if not source.exists():
        raise NotFound(f"{source} does not exist")
    stages = Stages(
        out / FINGERPRINTS,
        {name: p[DONE[name]] for name in STAGES},
        fingerprints(config, source, ruler, gate),
        progress,
    )
    stage, timings = stages.run, stages.timings

    pictures: list[str] = []
    try:
        stage("inputs", lambda: inputs.run(config, source, out, gate=gate))
        record = read_json(p["inputs"], InputSet)
        pictures = record.pictures
        stage("sfm", lambda: sfm.run(conf, p["images"], record.pictures, out / "sfm", video=record.video))
        stage("scale", lambda: scale.run(conf, p["sfm_model"], p["images"], out / "scale", ruler))
        stage("dense", lambda: dense.run(conf, p["sfm_model"], p["images"], p["scale"], out / "dense"))
        stage("mesh", lambda: mesh.run(conf, out / "dense", out / "mesh"))
    except CaptureInsufficient as exc:
        return _failed(out, p, exc.detail, FailureCode(exc.code), pictures, timings)
    except Exception as exc:
        _failed(
            out,
            p,
            f"the analysis stopped on an unexpected error ({exc}); the pictures are kept, "
            "please report this to your IT contact",
            FailureCode.internal_error,
            pictures,
            timings,
        )
        raise
    report = ReconstructionReport(
        outcome=Outcome.complete,
        pictures=pictures,
        sfm=read_json(p["sfm_quality"], SfmQuality),
        scale=_scale(p["scale"]),
        dense=read_json(p["mesh_quality"], DenseQuality),
        artifacts={k: str(v.relative_to(out)) for k, v in p.items() if v.exists()},
        timings=timings,
        software=software_versions(),
    )
    write_json(out / REPORT, report)
    return report


def _failed(
    out: Path, p: dict[str, Path], reason: str, code: FailureCode, pictures: list[str], timings: list[StageTiming]
) -> ReconstructionReport:
    report = ReconstructionReport(
        outcome=Outcome.failed,
        reason=reason,
        failure=code,
        pictures=pictures,
        sfm=_maybe(p["sfm_quality"], SfmQuality),
        scale=_scale(p["scale"]),
        timings=timings,
        software=software_versions(),
    )
    write_json(out / REPORT, report)
    return report


def _maybe(path: Path, kind: type):
    return read_json(path, kind) if path.exists() else None


def _scale(path: Path):
    return read_json(path, ScaleResult).estimate if path.exists() else None


def software_versions() -> dict[str, str]:
    versions = {}
    for package in (
        "burnedge",
        "pycolmap",
        "open3d",
        "opencv-python-headless",
        "onnxruntime",
        "numpy",
        "scipy",
        "trimesh",
    ):
        try:
            versions[package] = metadata.version(package)
        except metadata.PackageNotFoundError:
            continue
    return versions
