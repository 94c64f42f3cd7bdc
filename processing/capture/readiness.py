"""Is a capture set ready for 3D analysis? Enough accepted views, the marker in some, and views from around.

Viewpoint spread is measured from the marker: its four corners (known side in mm) give
each camera's pose relative to the marker plane (OpenCV's IPPE square solver), and the
spread is the largest angle between any two viewing directions. The intrinsics come from
the picture's 35 mm-equivalent focal length when it has one, else a phone's main camera.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import cv2
import numpy as np

from schemas.capture import CaptureReadiness, QualityVerdict
from schemas.config import QualityGateConfig, ReadinessConfig

FULL_FRAME_DIAGONAL_MM = 43.27
"""The 35 mm format's diagonal: "35 mm-equivalent" focal lengths are relative to it."""


@dataclass(frozen=True)
class View:
    verdict: QualityVerdict
    focal_35mm: float | None = None


def viewing_direction(view: View, marker_side_mm: float, default_focal_35mm: float) -> np.ndarray | None:
    """Unit vector from the marker to the camera, in the marker's frame; None without a marker."""
    figures = view.verdict.figures
    if figures is None or not figures.markers:
        return None
    w, h = figures.width, figures.height
    focal_px = (view.focal_35mm or default_focal_35mm) / FULL_FRAME_DIAGONAL_MM * float(np.hypot(w, h))
    k = np.array([[focal_px, 0, w / 2], [0, focal_px, h / 2], [0, 0, 1]], dtype=np.float64)
    half = marker_side_mm / 2
    square = np.array([[-half, half, 0], [half, half, 0], [half, -half, 0], [-half, -half, 0]], dtype=np.float64)
    marker = max(figures.markers, key=lambda m: m.side_px)
    corners = np.array(marker.corners_px, dtype=np.float64)
    ok, rvec, tvec = cv2.solvePnP(square, corners, k, None, flags=cv2.SOLVEPNP_IPPE_SQUARE)
    if not ok:
        return None
    rotation, _ = cv2.Rodrigues(rvec)
    camera = -rotation.T @ tvec.ravel()
    return camera / np.linalg.norm(camera)


def spread_deg(directions: list[np.ndarray]) -> float | None:
    if len(directions) < 2:
        return None
    cosines = [float(np.clip(a @ b, -1, 1)) for a, b in itertools.combinations(directions, 2)]
    return round(float(np.degrees(np.arccos(min(cosines)))), 1)


def assess(views: list[View], config: ReadinessConfig, gate: QualityGateConfig) -> CaptureReadiness:
    accepted = [v for v in views if v.verdict.accepted]
    directions = [
        d for v in accepted if (d := viewing_direction(v, gate.marker_side_mm, config.default_focal_35mm)) is not None
    ]
    spread = spread_deg(directions)
    missing = []
    if len(accepted) < config.min_views:
        missing.append(f"At least {config.min_views} usable photos are needed ({len(accepted)} so far): "
                       "take more, or film a slow circle around the burn.")  # fmt: skip
    if len(directions) < config.min_marker_views:
        missing.append(f"The scale marker must be visible in at least {config.min_marker_views} usable photos "
                       f"({len(directions)} so far): lay it flat on the skin next to the burn.")  # fmt: skip
    if spread is not None and spread < config.min_spread_deg:
        missing.append(f"The photos were taken from nearly one spot ({spread:.0f}° apart, {config.min_spread_deg:.0f}° "
                       "needed): walk around the burn, keeping it in view.")  # fmt: skip
    return CaptureReadiness(ready=not missing, views=len(views), accepted_views=len(accepted), marker_views=len(directions),
                            viewpoint_spread_deg=spread, missing=missing)  # fmt: skip
