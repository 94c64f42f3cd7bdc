"""How the quality gate's figures move with blur and exposure, on real-looking phantom views.

    .venv/bin/python -m benchmarks.gate_calibration [--views 6]

Takes sharp, well-exposed views from ../shared/phantoms, degrades each with a Gaussian blur
of growing sigma (full-resolution pixels) and with exposure gains, and prints the gate's
figures next to its thresholds. docs/quality-gate.md records the result.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np

from processing.capture.quality import gate_bytes
from schemas.config import QualityGateConfig

SHARED = Path(__file__).resolve().parents[2] / "shared" / "phantoms"
SIGMAS = [0.0, 1.0, 2.0, 3.0, 4.0, 6.0]
GAINS = [0.2, 0.35, 0.5, 1.0, 1.6, 2.2, 3.0]


def _encode(img: np.ndarray) -> bytes:
    return cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, 90])[1].tobytes()


def _gain(img: np.ndarray, gain: float) -> np.ndarray:
    linear = (img.astype(np.float32) / 255.0) ** 2.2 * gain  # work in linear light, as exposure does
    return (np.clip(linear, 0, 1) ** (1 / 2.2) * 255).round().astype(np.uint8)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--views", type=int, default=6)
    args = parser.parse_args(argv)
    views = sorted(SHARED.glob("*/images/view_00[0-9].jpg"))[:: max(1, 30 // args.views)][: args.views]
    if not views:
        raise SystemExit(f"no phantom views under {SHARED}")
    config = QualityGateConfig()
    print(f"blur: local sharpness (threshold {config.min_local_sharpness}) by Gaussian sigma, {len(views)} views")
    print("sigma  " + "  ".join(f"{s:>6}" for s in SIGMAS))
    for path in views:
        img = cv2.imread(str(path))
        row = []
        for sigma in SIGMAS:
            blurred = cv2.GaussianBlur(img, (0, 0), sigma) if sigma else img
            row.append(gate_bytes(_encode(blurred), config, name=path.name).figures.local_sharpness)
        print(f"{path.parent.parent.name[:6]}/{path.stem}  " + "  ".join(f"{v:6.0f}" for v in row))
    print(
        f"\nexposure: mean intensity (limits {config.min_mean_intensity}-{config.max_mean_intensity}),"
        f" bright fraction (limit {config.max_bright_fraction}) by linear gain"
    )
    print("gain   " + "  ".join(f"{g:>11}" for g in GAINS))
    for path in views:
        img = cv2.imread(str(path))
        cells = []
        for gain in GAINS:
            v = gate_bytes(_encode(_gain(img, gain)), config, name=path.name)
            flag = "x" if not v.accepted else " "
            cells.append(f"{v.figures.mean_intensity:5.0f}/{v.figures.bright_fraction:4.2f}{flag}")
        print(f"{path.parent.parent.name[:6]}/{path.stem}  " + "  ".join(cells))
    print("(x = rejected)")


if __name__ == "__main__":
    main()
