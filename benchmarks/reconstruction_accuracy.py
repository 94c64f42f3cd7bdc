"""Reconstruction accuracy on phantoms (ours and the independent ones) and SfM on the real skull photos.

    .venv/bin/python -m benchmarks.reconstruction_accuracy [--ours forearm,patch,foot] [--shared p1_forearm,...]

Goals (issue 4), after scaling with the marker alone: surface distance inside the burn median
<= 0.3 mm and 95th percentile <= 1.0 mm, scale error <= 0.5 %, >= 95 % of views registered; on
the skull set (no ground truth) all or nearly all views registered with mean reprojection
error below 1 px (with --skull-thorough: the default settings are tuned for speed on skin). See processing/reconstruction/evaluation.py for how each figure is measured.
The same-run baseline for the surface figures is the sparse SfM points: their distance to the
truth over the burn, placed the same way.
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

from processing.phantom.generate import run as render_phantom
from processing.reconstruction import pipeline, sfm
from processing.reconstruction.evaluation import evaluate, sparse_baseline
from schemas.config import Config
from schemas.phantom import PhantomShape, PhantomSpec

SHARED = Path(__file__).resolve().parents[2] / "shared"


def phantom_row(images_parent: Path, work: Path) -> dict:
    t = time.perf_counter()
    report = pipeline.run(Config(), images_parent / "images", work)
    seconds = time.perf_counter() - t
    if report.outcome.value != "complete":
        return {"phantom": images_parent.name, "outcome": report.outcome.value, "reason": report.reason}
    accuracy = evaluate(work, images_parent).as_dict()
    baseline = sparse_baseline(work, images_parent)
    accuracy["sparse_baseline_median_mm"] = None if baseline is None else round(baseline, 3)
    accuracy["seconds"] = round(seconds, 1)
    accuracy["scale_source"] = report.scale.source.value
    accuracy["reprojection_px"] = report.sfm.mean_reprojection_error_px
    return {k: (round(v, 4) if isinstance(v, float) else v) for k, v in accuracy.items()}


def skull_row(work: Path, thorough: bool) -> dict:
    folder = SHARED / "datasets" / "skull-multiview" / "images"
    names = sorted(p.name for p in folder.iterdir() if p.suffix.lower() == ".jpg")
    conf = Config().reconstruction
    if thorough:
        conf = msgspec.structs.replace(conf, **sfm.THOROUGH)
    t = time.perf_counter()
    database = work / "database.db"
    work.mkdir(parents=True, exist_ok=True)
    sfm.extract(conf, folder, names, database)
    sfm.match(conf, names, folder, database, work, video=False)
    models = sfm.incremental_map(conf, folder, names, database, work / "models")
    best = models[0]
    return {
        "set": "skull-multiview",
        "settings": "thorough" if thorough else "default",
        "views": len(names),
        "registered": best.num_reg_images(),
        "models": len(models),
        "mean_reprojection_px": round(best.compute_mean_reprojection_error(), 3),
        "seconds": round(time.perf_counter() - t, 1),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ours", default="forearm,patch,foot", help="shapes to render (12 views, 1920x1440)")
    parser.add_argument("--shared", default="p1_forearm,p2_foot,p3_thigh,p4_series_foot/session_day00")
    parser.add_argument("--no-skull", action="store_true")
    parser.add_argument("--skull-thorough", action="store_true", help="also run the skull with THOROUGH settings")
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for i, shape in enumerate(s for s in args.ours.split(",") if s):
            scene = Path(tmp) / f"ours_{shape}"
            render_phantom(PhantomSpec(shape=PhantomShape(shape), seed=20 + i), scene)
            rows.append(phantom_row(scene, Path(tmp) / f"analysis_{shape}"))
            print(json.dumps(rows[-1]), flush=True)
        for name in (s for s in args.shared.split(",") if s):
            scene = SHARED / "phantoms" / name
            if not scene.exists():
                print(f"skipped {name}: ../shared/phantoms is not here")
                continue
            rows.append(phantom_row(scene, Path(tmp) / f"analysis_{name.replace('/', '_')}"))
            print(json.dumps(rows[-1]), flush=True)
        skull = []
        if not args.no_skull and (SHARED / "datasets" / "skull-multiview").exists():
            for thorough in (False, True) if args.skull_thorough else (False,):
                skull.append(skull_row(Path(tmp) / f"skull{int(thorough)}", thorough))
                print(json.dumps(skull[-1]), flush=True)
    done = [r for r in rows if "surface_median_mm" in r]
    print(
        json.dumps(
            {
                "date": dt.date.today().isoformat(),
                "machine": f"{platform.machine()}, {os.cpu_count()} cores",
                "worst_surface_median_mm": max((r["surface_median_mm"] for r in done), default=None),
                "worst_surface_p95_mm": max((r["surface_p95_mm"] for r in done), default=None),
                "worst_abs_scale_error": max((abs(r["scale_error"]) for r in done), default=None),
                "min_registered_share": min((r["registered"] / r["views"] for r in done), default=None),
                "median_seconds": float(np.median([r["seconds"] for r in done])) if done else None,
                "rows": rows,
                "skull": skull,
            },
            indent=2,
        )
    )


if __name__ == "__main__":
    main()
