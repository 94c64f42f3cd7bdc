"""Burn segmentation time per view on one core, next to reading the same photo.

    .venv/bin/python -m benchmarks.segmentation_speed [--repeat 3] [--count 40] [--compare OTHER.onnx]

Goal (issues 5 and 20): <= 50 ms per view on one core, end to end: both passes of the model
(processing/segmentation/passes.py) with every resize in and out. The process is pinned to one CPU
and onnxruntime to one thread. Same-run baseline: decoding the photo (cv2.imread), which every
analysis pays anyway. Default photos: the FUSeg wound photos (512 x 512, the whole photo) and the
shared p1 phantom views (1920 x 1440, the model sees a crop around the burn). --compare times another
model file (e.g. the one shipped before) on the same photos in the same run, each with its own passes.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import platform
import statistics
import time
from pathlib import Path

import cv2
import msgspec
import numpy as np

from processing.segmentation.infer import SHIPPED_MODEL, Box, BurnSegmenter
from schemas.segmentation import PassSettings

SHARED = Path(__file__).resolve().parents[2] / "shared"


def timed(fn, repeat: int) -> float:
    best = []
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        best.append(time.perf_counter() - start)
    return min(best) * 1000


def measure(photos: list[Path], segmenter: BurnSegmenter, one_pass: BurnSegmenter, repeat: int, crop: bool) -> dict:
    read_ms, model_ms, one_ms = [], [], []
    for photo in photos:
        read_ms.append(timed(lambda p=photo: cv2.imread(str(p)), repeat))
        rgb = cv2.cvtColor(cv2.imread(str(photo)), cv2.COLOR_BGR2RGB)
        h, w = rgb.shape[:2]
        box = Box.around(w / 2, h / 2, min(h, w) / 3, w, h) if crop else None
        model_ms.append(timed(lambda r=rgb, b=box: segmenter.probability(r, b), repeat))
        one_ms.append(timed(lambda r=rgb, b=box: one_pass.probability(r, b), repeat))
    read, model, one = statistics.median(read_ms), statistics.median(model_ms), statistics.median(one_ms)
    return {
        "photos": len(photos),
        "size": f"{w}x{h}",
        "view": "crop" if crop else "whole picture",
        "model_ms_median": round(model, 1),
        "model_ms_p90": round(float(np.percentile(model_ms, 90)), 1),
        "read_photo_ms_median": round(read, 1),
        "model_over_read": round(model / read, 2),
        "one_pass_192_ms_median": round(one, 1),
        "model_over_one_pass": round(model / one, 2),
    }


def rows_for(model: Path, sets: list[tuple[list[Path], bool]], repeat: int) -> dict:
    segmenter = BurnSegmenter(model, threads=1)
    # Same-run baseline: the same model run as the earlier one was, one pass over the region at 192 (23.5 ms
    # per view on this machine when it was quiet, 2026-11-22).
    single = PassSettings(coarse_size=192, fine_size=192, threshold=0.5, fine_pass=False)
    one_pass = BurnSegmenter(model, threads=1, settings=single)
    return {
        "model": segmenter.metadata.get("version", ""),
        "architecture": segmenter.metadata.get("architecture", ""),
        "passes": msgspec.to_builtins(segmenter.settings),
        "rows": [measure(photos, segmenter, one_pass, repeat, crop) for photos, crop in sets if photos],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--count", type=int, default=40, help="photos per set")
    parser.add_argument("--compare", type=Path, action="append", default=[], help="another ONNX model to time")
    args = parser.parse_args()
    os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    sets = [
        (sorted((SHARED / "datasets" / "fuseg2021-train" / "images").glob("*.jpg"))[: args.count], False),
        (sorted((SHARED / "phantoms" / "p1_forearm" / "images").glob("*.jpg"))[: args.count], True),
    ]
    report = {
        "date": dt.date.today().isoformat(),
        "machine": f"{platform.processor() or platform.machine()}, pinned to 1 core",
        "models": [rows_for(model, sets, args.repeat) for model in [SHIPPED_MODEL, *args.compare]],
    }
    print(json.dumps(report, indent=2))


if __name__ == "__main__":
    main()
