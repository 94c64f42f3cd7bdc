"""Frame extraction time next to decoding the whole clip, in the same run.

    .venv/bin/python -m benchmarks.frames_speed [--runs 3]

Goal (issue 3): for a 10 s 1080p30 video, extraction <= 1.2 x a bare decode of all frames.
Two baselines, both over all frames: the decoder alone (PyAV, default threading: the strict
one), and decode-to-image (OpenCV VideoCapture.read, what a vision pipeline's "read every
frame" costs). Clips: 1080p30 H.264 made from a phantom view with I/P frames only (as phone
hardware encoders write) and with B-frames (as x264 writes), and the shared phantom's own
720p phone-like clip.
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

import av
import cv2

from benchmarks.phone_video import SHARED, make_phone_video
from processing.capture.frames import extract
from schemas.config import FramesConfig, QualityGateConfig


def _decoder_only(path: Path) -> float:
    t = time.perf_counter()
    with av.open(str(path)) as container:
        for _ in container.decode(video=0):
            pass
    return time.perf_counter() - t


def _decode_to_image(path: Path) -> float:
    t = time.perf_counter()
    capture = cv2.VideoCapture(str(path))
    while capture.read()[0]:
        pass
    capture.release()
    return time.perf_counter() - t


def _median(fn, path: Path, runs: int) -> float:
    return statistics.median(fn(path) for _ in range(runs))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args(argv)
    print(
        f"frame extraction, {dt.date.today()}, {platform.machine()}, {os.cpu_count()} cores, "
        f"Python {platform.python_version()}, PyAV {av.__version__}; medians of {args.runs} runs"
    )
    print(
        f"{'clip':<28}{'decoder s':>10}{'to-image s':>11}{'extract s':>10}{'x decoder':>10}{'x to-image':>11}  frames"
    )
    with tempfile.TemporaryDirectory() as tmp:
        clips = {
            "1080p30 10 s, I/P only": make_phone_video(Path(tmp) / "ip.mp4"),
            "1080p30 10 s, B-frames": make_phone_video(Path(tmp) / "b.mp4", bframes=3),
            "phantom 720p30 10 s": SHARED / "p2_foot" / "video.mp4",
        }
        for name, path in clips.items():
            decoder = _median(_decoder_only, path, args.runs)
            to_image = _median(_decode_to_image, path, args.runs)
            results = [extract(path, FramesConfig(), QualityGateConfig()) for _ in range(args.runs)]
            took = statistics.median(r.seconds for r in results)
            r = results[0]
            accepted = sum(f.verdict.accepted for f in r.frames)
            print(
                f"{name:<28}{decoder:>10.3f}{to_image:>11.3f}{took:>10.3f}{took / decoder:>10.2f}{took / to_image:>11.2f}"
                f"  {len(r.frames)} kept ({accepted} accepted), {len(r.skipped_duplicates)} near-duplicates, "
                f"{r.decoded} decoded"
            )


if __name__ == "__main__":
    main()
