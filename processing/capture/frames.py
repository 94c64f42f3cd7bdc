"""A video becomes a multi-view set: the sharpest frame of each slice of the clip, minus near-duplicates.

One decoding pass over the reference frames (B-frames are skipped). Each frame's sharpness
is measured on a strided view of its luma plane (no copy, no colour conversion; 10-bit HDR
video is shifted down to 8 bits), and only the best frame of each slice is kept in memory.
As soon as the decoder has passed a slice, its pick is compared with the last kept frame
(too little camera motion: dropped as a near-duplicate), and a worker thread turns it
upright (phone rotation tag), encodes it as JPEG and gates it while decoding goes on: the
decoder leaves about a quarter of the two cores idle, and this work fills it.
"""

from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import av
import cv2
import numpy as np

from processing.capture.quality import gate_pixels
from schemas.capture import QualityVerdict
from schemas.config import FramesConfig, QualityGateConfig
from schemas.errors import InvalidInput, plain


@dataclass
class _Pick:
    time_s: float
    sharpness: float
    frame: av.VideoFrame


@dataclass(frozen=True)
class ExtractedFrame:
    time_s: float
    jpeg: bytes
    sharpness: float
    verdict: QualityVerdict


@dataclass
class Extraction:
    frames: list[ExtractedFrame]
    decoded: int
    """Frames decoded (every frame of the clip)."""
    skipped_duplicates: list[float] = field(default_factory=list)
    """Times of picks dropped as near-duplicates of the frame before."""
    seconds: float = 0.0


def luma(frame: av.VideoFrame, step: int) -> np.ndarray:
    """Every `step`-th pixel of the frame's Y plane, as 8-bit grey.

    8-bit video: a strided view of the plane (no copy, no conversion). 10- or 12-bit video
    (iPhone HDR HEVC): its samples are 16-bit words, so the subsampled view is shifted down
    to 8 bits (a copy, of the subsampled size only).
    """
    plane, fmt = frame.planes[0], frame.format
    bits = fmt.components[0].bits
    if bits <= 8:
        y = np.frombuffer(plane, np.uint8).reshape(plane.height, plane.line_size)[:, : plane.width]
        return y[::step, ::step]
    words = np.frombuffer(plane, ">u2" if fmt.is_big_endian else "<u2")
    y = words.reshape(plane.height, plane.line_size // 2)[:, : plane.width][::step, ::step]
    # P010-style formats keep the sample in the high bits of each word, yuv420p10le in the low ones.
    msb_aligned = fmt.name[:1] == "p" and fmt.name[1:4].isdigit()
    return (y >> (16 - 8 if msb_aligned else bits - 8)).astype(np.uint8)


def extract(path: str | Path, config: FramesConfig, gate: QualityGateConfig, *, name: str = "video") -> Extraction:
    """The video's multi-view set: upright JPEG frames, each gated like a photo (InvalidInput if it does not decode)."""
    start = time.perf_counter()
    out = Extraction(frames=[], decoded=0)
    with ThreadPoolExecutor(max_workers=1) as worker:
        rendered = []
        last_kept: list[np.ndarray] = []

        def finish(pick: _Pick) -> None:
            small = luma(pick.frame, 8).astype(np.float32)
            if last_kept and not _moved(last_kept[0], small, config):
                out.skipped_duplicates.append(round(pick.time_s, 3))
                return
            last_kept[:] = [small]
            rendered.append(worker.submit(_render, pick, config, gate, name))

        out.decoded = _pick_sharpest(Path(path), config, finish)
        out.frames = [f.result() for f in rendered]
    out.seconds = time.perf_counter() - start
    return out


def _pick_sharpest(path: Path, config: FramesConfig, finish) -> int:
    """Decode every frame; hand each slice's sharpest frame to `finish` once the slice is over."""
    slices = max(1, config.max_frames)
    try:
        with av.open(str(path)) as container:
            if not container.streams.video:
                raise InvalidInput("the file has no video track")
            stream = container.streams.video[0]
            stream.thread_type = "SLICE"
            # B-frames are never references: skipping them decodes fewer frames, and the I/P frames
            # left carry more bits (a lower quantiser) than B-frames, which suits 3D reconstruction.
            stream.codec_context.skip_frame = "BIDIR"
            duration = _duration(container, stream)
            current, best, decoded = 0, None, 0
            for frame in container.decode(stream):
                decoded += 1
                t = float(frame.time or 0.0)
                k = min(slices - 1, int(t / duration * slices)) if duration > 0 else 0
                if k != current and best is not None:
                    finish(best)
                    best = None
                current = k
                sharp = float(cv2.Laplacian(luma(frame, config.sharpness_step), cv2.CV_32F).var())
                if best is None or sharp > best.sharpness:
                    best = _Pick(t, sharp, frame)
            if best is not None:
                finish(best)
    except av.FFmpegError as exc:
        raise InvalidInput(f"the video could not be decoded: {plain(exc)}") from exc
    if decoded == 0:
        raise InvalidInput("the video has no decodable frames")
    return decoded


def _render(pick: _Pick, config: FramesConfig, gate: QualityGateConfig, name: str) -> ExtractedFrame:
    turns = upright_turns(pick.frame)
    bgr = np.ascontiguousarray(np.rot90(pick.frame.to_ndarray(format="bgr24"), turns))
    ok, buf = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, config.jpeg_quality])
    if not ok:
        raise InvalidInput("a video frame could not be encoded as JPEG")
    gray = np.ascontiguousarray(np.rot90(luma(pick.frame, 1), turns))
    verdict = gate_pixels(gray, gate, name=f"{name}@{pick.time_s:.3f}s")
    return ExtractedFrame(
        time_s=round(pick.time_s, 3), jpeg=buf.tobytes(), sharpness=round(pick.sharpness, 1), verdict=verdict
    )


def upright_turns(frame: av.VideoFrame) -> int:
    """Quarter turns, counter-clockwise as np.rot90 counts them, that show the frame upright.

    The display matrix's rotation is the counter-clockwise angle a player turns the picture by
    (an iPhone held upright records landscape pictures tagged -90: a quarter turn clockwise).
    """
    return round((getattr(frame, "rotation", 0) or 0) / 90) % 4


def _duration(container, stream) -> float:
    if stream.duration and stream.time_base:
        return float(stream.duration * stream.time_base)
    return (container.duration or 0) / 1e6


def _moved(a: np.ndarray, b: np.ndarray, config: FramesConfig) -> bool:
    (dx, dy), _ = cv2.phaseCorrelate(a, b)
    shift = float(np.hypot(dx, dy)) / a.shape[1]
    difference = float(np.mean(np.abs(a - b)))
    return shift >= config.min_motion_fraction or difference >= config.min_difference
