"""Quality-gate latency on a 12-megapixel phone JPEG, next to a full-resolution decode of it.

    .venv/bin/python -m benchmarks.gate_speed [--runs 40]

Goal (issue 3): p95 from upload completion (the file on disk) to verdict <= 150 ms on the
2-core mini-PC, and the gate cheaper than decoding the JPEG at full resolution. The picture
is a phantom view from ../shared scaled to 4032 x 3024 (a 12 MP phone camera) with sensor-like
noise added, saved at JPEG quality 92.
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import platform
import statistics
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from processing.capture.quality import gate_file
from schemas.config import QualityGateConfig

VIEW = Path(__file__).resolve().parents[2] / "shared" / "phantoms" / "p2_foot" / "images" / "view_003.jpg"


def phone_jpeg(path: Path) -> None:
    img = cv2.resize(cv2.imread(str(VIEW)), (4032, 3024), interpolation=cv2.INTER_CUBIC)
    noise = np.random.default_rng(0).normal(0, 3.0, img.shape)
    cv2.imwrite(str(path), np.clip(img + noise, 0, 255).astype(np.uint8), [cv2.IMWRITE_JPEG_QUALITY, 92])


def _times(fn, runs: int) -> list[float]:
    out = []
    for _ in range(runs):
        t0 = time.perf_counter()
        fn()
        out.append((time.perf_counter() - t0) * 1000)
    return out


def _pct(values: list[float], q: float) -> float:
    return sorted(values)[min(len(values) - 1, int(q / 100 * len(values)))]


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=40)
    args = parser.parse_args(argv)
    if not VIEW.exists():
        raise SystemExit(f"needs the shared phantoms: {VIEW} is missing")
    config = QualityGateConfig()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "phone.jpg"
        phone_jpeg(path)
        size_mb = path.stat().st_size / 1e6
        verdict = gate_file(path, config)
        gate = _times(lambda: gate_file(path, config), args.runs)
        decode = _times(lambda: cv2.imread(str(path), cv2.IMREAD_COLOR), args.runs)
    report = {
        "date": dt.date.today().isoformat(),
        "machine": f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, OpenCV {cv2.__version__}",
        "image": f"4032 x 3024 JPEG q92, {size_mb:.1f} MB, accepted={verdict.accepted}, markers={len(verdict.figures.markers)}",
        "gate_ms": {"p50": round(statistics.median(gate), 1), "p95": round(_pct(gate, 95), 1)},
        "full_decode_ms": {"p50": round(statistics.median(decode), 1), "p95": round(_pct(decode, 95), 1)},
    }
    report["gate_vs_decode"] = round(report["gate_ms"]["p50"] / report["full_decode_ms"]["p50"], 2)
    print(f"quality gate, {report['date']}, {report['machine']}")
    print(f"  {report['image']}, {args.runs} runs each")
    print(
        f"  gate (file read + verdict): p50 {report['gate_ms']['p50']} ms, p95 {report['gate_ms']['p95']} ms (goal p95 <= 150)"
    )
    print(
        f"  full-resolution decode:     p50 {report['full_decode_ms']['p50']} ms, p95 {report['full_decode_ms']['p95']} ms"
    )
    print(f"  gate / decode: {report['gate_vs_decode']} (goal < 1)")
    return report


if __name__ == "__main__":
    main()
