"""The instant quality gate: is this picture usable, and what should the person holding the phone do?

Figures are computed on a greyscale copy at `analysis_long_side` pixels, so the thresholds
hold whatever the phone's resolution. Sharpness is the variance of the Laplacian (the seed's
blur test), over the whole picture and, as the deciding figure, over the central region where
the burn usually is: a sharp background cannot hide a blurred wound. Thresholds and their
calibration: docs/quality-gate.md.
"""

from __future__ import annotations

import time
from pathlib import Path

import cv2
import numpy as np

from processing.capture.images import AnalysisImage, ImageHeader, analysis_copy, load_for_analysis
from processing.capture.marker import find_markers
from schemas.capture import REJECTING, MarkerSighting, QualityFigures, QualityReason, QualityVerdict
from schemas.config import QualityGateConfig
from schemas.errors import InvalidInput

GUIDANCE = {
    QualityReason.unreadable: "This file is not a photo the gateway can read: take the picture again with the camera app.",
    QualityReason.too_small: "Use the phone's main camera at full resolution (at least 800 x 600 pixels).",
    QualityReason.blurry: "Hold the phone still (brace your elbows) and tap the burn on the screen to focus before taking the picture.",
    QualityReason.too_dark: "More light: switch on the room light or the phone's torch, or move the patient towards a window.",
    QualityReason.too_bright: "Too much light: avoid direct sunlight and flash glare on the skin, or tilt the phone slightly.",
    QualityReason.no_marker: "Keep the scale marker in view: lay it flat on the skin next to the burn.",
    QualityReason.marker_too_small: "Move closer: the scale marker is too small in the picture for a precise scale.",
}
GRID = (8, 6)
"""Tiles across and down; the central region is the grid without its outer ring."""


def gate_file(path: str | Path, config: QualityGateConfig) -> QualityVerdict:
    return gate_bytes(Path(path).read_bytes(), config, name=str(path))


def gate_bytes(data: bytes, config: QualityGateConfig, *, name: str) -> QualityVerdict:
    start = time.perf_counter()
    try:
        image = load_for_analysis(data, long_side=config.analysis_long_side, max_pixels=config.max_pixels)
    except InvalidInput as exc:
        return QualityVerdict(
            file=name,
            accepted=False,
            reasons=[QualityReason.unreadable],
            guidance=[f"{GUIDANCE[QualityReason.unreadable]} ({exc.detail})"],
            figures=None,
        )

    def finer() -> AnalysisImage:
        return load_for_analysis(data, long_side=2 * config.analysis_long_side, max_pixels=config.max_pixels)

    return gate_image(image, config, name=name, finer=finer, start=start)


def gate_pixels(gray: np.ndarray, config: QualityGateConfig, *, name: str) -> QualityVerdict:
    """The gate on pixels already in memory (a video frame's luma), full resolution."""
    start = time.perf_counter()
    height, width = gray.shape
    image = analysis_copy(gray, ImageHeader("frame", width, height, 1), config.analysis_long_side)

    def finer() -> AnalysisImage:
        return analysis_copy(gray, image.header, 2 * config.analysis_long_side)

    return gate_image(image, config, name=name, finer=finer, start=start)


def gate_image(image: AnalysisImage, config: QualityGateConfig, *, name: str, finer, start: float) -> QualityVerdict:
    markers = find_markers(image.gray, image.scale, config.marker_dictionary)
    if not markers and image.scale <= 0.5:
        # A marker far from the camera can be too small at the analysis scale: look once more, twice as large.
        detail = finer()
        markers = find_markers(detail.gray, detail.scale, config.marker_dictionary)
    figures = _figures(image, markers, config, time.perf_counter() - start)
    reasons = judge(figures, config)
    return QualityVerdict(
        file=name,
        accepted=not (set(reasons) & REJECTING),
        reasons=reasons,
        guidance=[GUIDANCE[r] for r in reasons],
        figures=figures,
    )


def judge(f: QualityFigures, config: QualityGateConfig) -> list[QualityReason]:
    reasons = []
    if max(f.width, f.height) < config.min_width or min(f.width, f.height) < config.min_height:
        reasons.append(QualityReason.too_small)
    if f.local_sharpness < config.min_local_sharpness:
        reasons.append(QualityReason.blurry)
    if f.mean_intensity < config.min_mean_intensity or f.dark_fraction > config.max_dark_fraction:
        reasons.append(QualityReason.too_dark)
    if f.mean_intensity > config.max_mean_intensity or f.bright_fraction > config.max_bright_fraction:
        reasons.append(QualityReason.too_bright)
    if not f.markers:
        reasons.append(QualityReason.no_marker)
    elif max(m.side_px for m in f.markers) < config.min_marker_side_px:
        reasons.append(QualityReason.marker_too_small)
    return reasons


def _figures(
    image: AnalysisImage, markers: list[MarkerSighting], config: QualityGateConfig, seconds: float
) -> QualityFigures:
    gray = image.gray
    lap = cv2.Laplacian(gray, cv2.CV_32F)
    return QualityFigures(
        width=image.header.width,
        height=image.header.height,
        analysis_long_side=max(gray.shape),
        sharpness=round(float(lap.var()), 1),
        local_sharpness=round(central_sharpness(lap), 1),
        mean_intensity=round(float(gray.mean()), 1),
        dark_fraction=round(float(np.count_nonzero(gray <= config.dark_level)) / gray.size, 4),
        bright_fraction=round(float(np.count_nonzero(gray >= config.bright_level)) / gray.size, 4),
        markers=markers,
        seconds=round(seconds, 4),
    )


def central_sharpness(lap: np.ndarray) -> float:
    """75th percentile of the per-tile Laplacian variance over the central tiles."""
    cols, rows = GRID
    h, w = lap.shape
    tiles = [
        lap[r * h // rows : (r + 1) * h // rows, c * w // cols : (c + 1) * w // cols].var()
        for r in range(1, rows - 1)
        for c in range(1, cols - 1)
    ]
    return float(np.percentile(tiles, 75))
