"""Healing over time on phantom series with known limb motion and known shrinkage.

    .venv/bin/python -m benchmarks.healing_track [--work DIR] [--series p4,ours5,...] [--masks true,model]
        [--model-file OTHER.onnx]

Series: the independent ../shared/phantoms/p4_series_foot (6 views per session, 1920x1440) and our own rendered
forearm series (`oursS`: processing.phantom.generate.run_series with seed S, 8 views, 960x720, the size the tests
use). Each session is analysed with the true masks (given as a person's masks) and/or the segmentation model,
then `processing.longitudinal.track.run` registers and compares them. Goals (issue 6): registration error
<= 1 mm RMS on the healthy skin, area-change error <= 3 percentage points at every session.

The registration error is measured against the truth independently of the registration: each session's
reconstruction frame is mapped to that session's phantom world by a similarity fit of the reconstructed camera
centres (COLMAP, in the output frame) to the true ones; the true follow-up -> baseline transform is then
S_0^-1 M^-1 S_t (M = world_day0_to_world_this), compared with the estimate on the follow-up's healthy skin (mesh
vertices 5-25 mm outside its burn, over 4 mm above the drape z = 0 of the phantom world).

Same-run baselines on the same surfaces: the marker frames taken as one (identity: the marker is laid down afresh
at every visit), ICP alone from identity (point-to-plane, 10 -> 0.8 mm), and FPFH + RANSAC + ICP on shape alone
(no texture descriptor).
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import platform
import tempfile
import time
from pathlib import Path

import msgspec
import numpy as np

from processing.analysis.pipeline import run as analyze
from processing.analysis.surface_map import output_views
from processing.longitudinal import registration, track
from processing.phantom.generate import run_series
from processing.reconstruction.pipeline import paths as reconstruction_paths
from schemas.config import Config, TrackingConfig
from schemas.errors import InvalidInput
from schemas.phantom import PhantomSpec

SHARED = Path(__file__).resolve().parents[2] / "shared" / "phantoms" / "p4_series_foot"
SMALL = {"views": 8, "width": 960, "height": 720}
EVAL_RING_MM = (5.0, 25.0)
DRAPE_CLEARANCE_MM = 4.0


def similarity(source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Umeyama: the 4x4 similarity taking `source` points onto `target` (least squares)."""
    mu_s, mu_t = source.mean(axis=0), target.mean(axis=0)
    a, b = source - mu_s, target - mu_t
    u, singular, vt = np.linalg.svd(b.T @ a / len(source))
    d = np.eye(3)
    d[2, 2] = np.sign(np.linalg.det(u @ vt))
    rotation = u @ d @ vt
    scale = float(np.trace(np.diag(singular) @ d) / np.mean(np.sum(a**2, axis=1)))
    out = np.eye(4)
    out[:3, :3], out[:3, 3] = scale * rotation, mu_t - scale * rotation @ mu_s
    return out


def to_world(analysis: Path, session_truth: dict) -> tuple[np.ndarray, float]:
    """Similarity from the analysis's output frame to the phantom world, and its camera-centre RMS residual."""
    p = reconstruction_paths(analysis)
    views = output_views(p["sfm_model"], p["scale"])
    true = {c["name"]: -np.array(c["R"]).T @ np.array(c["t"]) for c in session_truth["cameras"]}
    source = np.array([v.centre for v in views])
    target = np.array([true[Path(v.name).stem] for v in views])
    s = similarity(source, target)
    residual = np.linalg.norm(source @ s[:3, :3].T + s[:3, 3] - target, axis=1)
    return s, float(np.sqrt(np.mean(residual**2)))


def apply(transform: np.ndarray, points: np.ndarray) -> np.ndarray:
    return points @ transform[:3, :3].T + transform[:3, 3]


def rms_apart(a: np.ndarray, b: np.ndarray, points: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum((apply(a, points) - apply(b, points)) ** 2, axis=1))))


def eval_skin(surface: registration.Surface, world: np.ndarray) -> np.ndarray:
    """The follow-up's healthy skin for scoring, chosen with the truth's drape plane (not the registration's)."""
    above = apply(world, surface.vertices)[:, 2] > DRAPE_CLEARANCE_MM
    conf = TrackingConfig(burn_margin_mm=EVAL_RING_MM[0])
    keep = registration.skin_mask(conf, surface, surface.burn_points, EVAL_RING_MM[1], [surface.burn_points], above)
    return surface.vertices[keep]


def icp_only(conf: TrackingConfig, base: registration.Surface, follow: registration.Surface) -> np.ndarray:
    """Baseline: ICP from identity on each visit's own healthy-skin ring (no global step)."""
    wide = msgspec.structs.replace(conf, icp_distances_mm=[10.0, 3.0, 1.5, 0.8])

    def ring(surface):
        usable = registration.off_plane(conf, surface)
        reach = conf.burn_margin_mm + conf.skin_ring_mm
        keep = registration.skin_mask(conf, surface, surface.burn_points, reach, [surface.burn_points], usable)
        return registration.skin_cloud(surface, keep, conf.fine_voxel_mm).cloud

    return np.array(registration.icp(wide, ring(follow), ring(base), np.eye(4)).transformation)


def least_squares_rate(days: list[float], areas: list[float]) -> float:
    return float(-np.polyfit(days, areas, 1)[0])


def series_folder(name: str, work: Path) -> Path:
    if name == "p4":
        if not (SHARED / "ground_truth.json").exists():
            raise InvalidInput(f"{SHARED} is missing")
        return SHARED
    seed = int(name.removeprefix("ours"))
    folder = work / name / "phantom"
    if not (folder / "ground_truth.json").exists():
        run_series(PhantomSpec(seed=seed, **SMALL), folder)
    return folder


def run_one(name: str, root: Path, work: Path, masks: str, config: Config) -> dict:
    series = json.loads((root / "ground_truth.json").read_text())
    listing = series["sessions"]
    analyses, sessions = [], []
    for entry in listing:
        scene = root / entry["dir"]
        out = work / name / "analyses" / entry["dir"]
        analyze(config, scene / "images", out, masks=scene / "masks" if masks == "true" else None)
        analyses.append(out)
        sessions.append(track.SessionAnalysis(day=float(entry["day"]), analysis_dir=out, label=entry["dir"]))
    conf = TrackingConfig()
    out_dir = work / name / f"track_{masks}"
    for stale in (out_dir / track.CACHE).glob("*.json"):  # time every registration afresh
        stale.unlink()
    started = time.perf_counter()
    result = json.loads(track.run(conf, sessions, out_dir).read_text())
    seconds = time.perf_counter() - started
    truths = [json.loads((root / e["dir"] / "ground_truth.json").read_text()) for e in listing]
    frames = [to_world(a, t) for a, t in zip(analyses, truths, strict=True)]
    base = registration.load_surface(analyses[0] / track.SURFACE, analyses[0] / track.MESH)
    shape_only = msgspec.structs.replace(conf, texture_feature_weight=0.0)
    rows = []
    for i, (entry, row) in enumerate(zip(listing, result["sessions"], strict=True)):
        true_change = 100 * (entry["area_ratio_vs_day0"] - 1)
        out = {
            "session": entry["dir"],
            "day": entry["day"],
            "true_area_cm2": round(entry["burn_area_cm2"], 3),
            "area_cm2": row["area_cm2"],
            "true_area_change_pct": round(true_change, 2),
            "area_change_pct": row["area_change_percent"],
            "area_change_err_pp": None
            if row["area_change_percent"] is None
            else round(row["area_change_percent"] - true_change, 2),
            "frame_fit_rms_mm": round(frames[i][1], 3),
        }
        if i > 0 and row["transform_to_baseline"] is not None:
            follow = registration.load_surface(analyses[i] / track.SURFACE, analyses[i] / track.MESH)
            truth = (
                np.linalg.inv(frames[0][0]) @ np.linalg.inv(np.array(entry["world_day0_to_world_this"])) @ frames[i][0]
            )
            skin = eval_skin(follow, frames[i][0])
            started = time.perf_counter()
            shape = registration.register(shape_only, base, follow)
            shape_seconds = time.perf_counter() - started
            out |= {
                "registration_err_mm": round(rms_apart(np.array(row["transform_to_baseline"]), truth, skin), 3),
                "reported_rmse_mm": row["registration_rmse_mm"],
                "overlap": row["registration_overlap"],
                "warning": row["registration_warning"],
                "eval_points": len(skin),
                "baseline_identity_err_mm": round(rms_apart(np.eye(4), truth, skin), 2),
                "baseline_icp_only_err_mm": round(rms_apart(icp_only(conf, base, follow), truth, skin), 2),
                "baseline_shape_only_err_mm": round(rms_apart(np.array(shape.transform_to_baseline), truth, skin), 3),
                "baseline_shape_only_agreeing": f"{shape.ransac_agreeing}/{shape.ransac_tries}",
                "baseline_shape_only_seconds": round(shape_seconds, 1),
            }
        rows.append(out)
    days = [e["day"] for e in listing]
    return {
        "series": name,
        "masks": masks,
        "rows": rows,
        "true_rate_cm2_per_day": round(least_squares_rate(days, [e["burn_area_cm2"] for e in listing]), 4),
        "rate_cm2_per_day": result["healing_rate_cm2_per_day"],
        "projected_closure_day": result["projected_closure_day"],
        "projected_closure_range_days": result["projected_closure_range_days"],
        "track_seconds": round(seconds, 1),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--work", default=os.path.join(tempfile.gettempdir(), "burnedge-bench-healing"))
    parser.add_argument("--series", default="p4,ours5,ours11", help="p4 and/or oursSEED, comma-separated")
    parser.add_argument("--masks", default="true,model", help="true and/or model, comma-separated")
    parser.add_argument("--model-file", default="", help="another ONNX model than the shipped one (model masks)")
    args = parser.parse_args()
    config = Config()
    if args.model_file:
        config = msgspec.structs.replace(
            config, analysis=msgspec.structs.replace(config.analysis, model=args.model_file)
        )
    work = Path(args.work)
    reports = []
    for name in [s for s in args.series.split(",") if s]:
        root = series_folder(name, work)
        for masks in [m for m in args.masks.split(",") if m]:
            report = run_one(name, root, work, masks, config)
            reports.append(report)
            for row in report["rows"]:
                print(json.dumps({"series": name, "masks": masks, **row}), flush=True)
            print(json.dumps({k: v for k, v in report.items() if k != "rows"}), flush=True)
    summary = {
        "date": dt.date.today().isoformat(),
        "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores",
        "reports": reports,
    }
    (work / "healing_track.json").write_text(json.dumps(summary, indent=2))


if __name__ == "__main__":
    main()
