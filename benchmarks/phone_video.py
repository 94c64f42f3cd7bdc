"""A phone-like test clip: a slow orbit over a phantom scene, H.264 1080p30 at about 10 Mbit/s."""

from __future__ import annotations

from pathlib import Path

import av
import cv2
import numpy as np

SHARED = Path(__file__).resolve().parents[2] / "shared" / "phantoms"


def make_phone_video(
    path: Path, seconds: float = 10.0, size: tuple[int, int] = (1920, 1080), fps: int = 30, *, bframes: int = 0
) -> Path:
    """Pans across an upscaled phantom view, with sensor noise, like a hand-held clip.

    bframes=0 is what phones' hardware encoders usually write (I and P frames only).
    """
    views = sorted(SHARED.glob("p2_foot/images/view_*.jpg"))
    if not views:
        raise FileNotFoundError(f"needs the shared phantoms in {SHARED}")
    w, h = size
    base = cv2.resize(cv2.imread(str(views[0])), (int(w * 1.6), int(h * 1.6)), interpolation=cv2.INTER_CUBIC)
    rng = np.random.default_rng(0)
    frames = int(seconds * fps)
    with av.open(str(path), "w") as out:
        stream = out.add_stream("libx264", rate=fps)
        stream.width, stream.height, stream.pix_fmt = w, h, "yuv420p"
        stream.bit_rate = 10_000_000
        stream.options = {"preset": "veryfast", "g": str(fps), "bf": str(bframes)}  # a keyframe a second
        for i in range(frames):
            u = i / max(1, frames - 1)
            x = int(u * (base.shape[1] - w))
            y = int((0.5 - 0.5 * np.cos(2 * np.pi * u)) * (base.shape[0] - h))
            crop = base[y : y + h, x : x + w].astype(np.int16) + rng.normal(0, 2.0, (h, w, 3)).astype(np.int16)
            rgb = cv2.cvtColor(np.clip(crop, 0, 255).astype(np.uint8), cv2.COLOR_BGR2RGB)
            for packet in stream.encode(av.VideoFrame.from_ndarray(rgb, format="rgb24")):
                out.mux(packet)
        for packet in stream.encode():
            out.mux(packet)
    return path
