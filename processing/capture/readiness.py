"""Is a capture set ready for 3D analysis? Enough accepted views, the marker in some, and views from around.

Viewpoint spread is measured from the marker: its four corners (known side in mm) give
each camera's pose relative to the marker plane (OpenCV's IPPE square solver), and the
spread is the largest angle between any two viewing directions. The intrinsics come from
the picture's 35 mm-equivalent focal length when it has one, else a phone's main camera.

A planar square has two poses that fit its corners (the second mirrors the tilt), and for
a small or nearly head-on marker the wrong one can fit almost as well: such a view is left
out of the spread rather than risk a direction flipped by twice the tilt. All views use
the same marker (a printed strip has several ids at different places on the skin), the
one seen in the most accepted views.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import cv2
import numpy as np

from schemas.capture import CaptureReadiness, MarkerSighting, QualityVerdict
from schemas.config import QualityGateConfig, ReadinessConfig

FULL_FRAME_DIAGONAL_MM = 43.27
"""The 35 mm format's diagonal: "35 mm-equivalent" focal lengths are relative to it."""
MIN_POSE_ERROR_RATIO = 2.0
"""The other pose's reprojection error must be at least this many times the best one's..."""
MIN_OTHER_POSE_ERROR_PX = 0.3
"""...and at least this many pixels (RMS), above the noise of detected corners, or the view is
ambiguous. Ratio alone lets noise pick the flipped pose of a 40-60 px marker (simulated with
0.1-0.3 px of corner noise: errors of 20-90 degrees kept); with both, the flips left are under
10 degrees. On the shared phantoms all 12 p3_thigh views count (other pose at 2.6 times and
0.39 px or more), p2_foot and p4 day 0 each lose one near-ambiguous view, and every spread
stays within 1.2 degrees of the truth."""


@dataclass(frozen=True)
class View:
    verdict: QualityVerdict
    focal_35mm: float | None = None


def pose_errors(
    view: View, sighting: MarkerSighting, marker_side_mm: float, default_focal_35mm: float
) -> tuple[np.ndarray, float, float] | None:
    """The best pose's viewing direction (unit vector, marker to camera, in the marker's frame), its
    reprojection error and the other pose's, in pixels; None if the solver finds no pose."""
    figures = view.verdict.figures
    w, h = figures.width, figures.height
    focal_px = (view.focal_35mm or default_focal_35mm) / FULL_FRAME_DIAGONAL_MM * float(np.hypot(w, h))
    k = np.array([[focal_px, 0, w / 2], [0, focal_px, h / 2], [0, 0, 1]], dtype=np.float64)
    half = marker_side_mm / 2
    square = np.array([[-half, half, 0], [half, half, 0], [half, -half, 0], [-half, -half, 0]], dtype=np.float64)
    corners = np.array(sighting.corners_px, dtype=np.float64)
    n, rvecs, tvecs, errors = cv2.solvePnPGeneric(square, corners, k, None, flags=cv2.SOLVEPNP_IPPE_SQUARE)
    if n == 0:
        return None
    errors = np.asarray(errors, dtype=np.float64).ravel()
    order = np.argsort(errors)
    best = int(order[0])
    rotation, _ = cv2.Rodrigues(rvecs[best])
    camera = -rotation.T @ np.asarray(tvecs[best]).ravel()
    other = float(errors[order[1]]) if n > 1 else float("inf")
    return camera / np.linalg.norm(camera), float(errors[best]), other


def viewing_direction(
    view: View, marker_id: int, marker_side_mm: float, default_focal_35mm: float
) -> np.ndarray | None:
    """Unit vector from marker `marker_id` to the camera, in the marker's frame.

    None means this view has no usable sighting of that marker: it does not show it, or its
    pose is ambiguous (see MIN_POSE_ERROR_RATIO). That is not an error, the view just does
    not count towards the spread.
    """
    figures = view.verdict.figures
    sighting = next((m for m in figures.markers if m.id == marker_id), None) if figures else None
    if sighting is None:
        return None
    solved = pose_errors(view, sighting, marker_side_mm, default_focal_35mm)
    if solved is None:
        return None
    direction, best, other = solved
    if other < MIN_POSE_ERROR_RATIO * best or other < MIN_OTHER_POSE_ERROR_PX:
        return None
    return direction


def marker_directions(views: list[View], marker_side_mm: float, default_focal_35mm: float) -> list[np.ndarray | None]:
    """The viewing directions from the marker seen in the most views, one per view showing it (None where
    ambiguous). Among markers seen equally often, the one giving more directions, then the lowest id."""
    by_id: dict[int, list[np.ndarray | None]] = {}
    for v in views:
        for marker_id in sorted({m.id for m in v.verdict.figures.markers} if v.verdict.figures else ()):
            by_id.setdefault(marker_id, []).append(viewing_direction(v, marker_id, marker_side_mm, default_focal_35mm))
    if not by_id:
        return []
    _, chosen = max(by_id.items(), key=lambda kv: (len(kv[1]), sum(d is not None for d in kv[1]), -kv[0]))
    return chosen


def spread_deg(directions: list[np.ndarray]) -> float | None:
    """Largest angle in degrees between two of the directions; None with fewer than two."""
    if len(directions) < 2:
        return None
    cosines = [float(np.clip(a @ b, -1, 1)) for a, b in itertools.combinations(directions, 2)]
    return round(float(np.degrees(np.arccos(min(cosines)))), 1)


def assess(views: list[View], config: ReadinessConfig, gate: QualityGateConfig) -> CaptureReadiness:
    """Whether the views are enough for 3D analysis, and what to do when they are not."""
    accepted = [v for v in views if v.verdict.accepted]
    sightings = marker_directions(accepted, gate.marker_side_mm, config.default_focal_35mm)
    directions = [d for d in sightings if d is not None]
    spread = spread_deg(directions)
    missing = []
    if len(accepted) < config.min_views:
        missing.append(
            f"At least {config.min_views} usable photos are needed ({len(accepted)} so far): "
            "take more, or film a slow circle around the burn."
        )
    if len(directions) < config.min_marker_views:
        hint = (
            "lay it flat on the skin next to the burn"
            if len(sightings) == len(directions)
            else "in some it is too small or seen straight on to tell the angle: come closer, and take photos "
            "from the sides too"
        )
        missing.append(
            f"The scale marker must be visible in at least {config.min_marker_views} usable photos "
            f"({len(directions)} so far): {hint}."
        )
    if spread is not None and spread < config.min_spread_deg:
        missing.append(
            f"The photos were taken from nearly one spot ({spread:.0f}° apart, {config.min_spread_deg:.0f}° "
            "needed): walk around the burn, keeping it in view."
        )
    return CaptureReadiness(
        ready=not missing,
        views=len(views),
        accepted_views=len(accepted),
        marker_views=len(directions),
        viewpoint_spread_deg=spread,
        missing=missing,
    )
