"""Capture intake: the quality verdict on each photo or video frame, and the stored assets."""

from __future__ import annotations

import enum

from schemas.base import Frozen


class QualityReason(enum.StrEnum):
    """Machine-readable reasons on a quality verdict."""

    unreadable = "unreadable"
    """Not a decodable image."""
    too_small = "too_small"
    """Below the minimum resolution (800 x 600 by default)."""
    blurry = "blurry"
    """Too little sharpness where the burn usually is (camera shake or missed focus)."""
    too_dark = "too_dark"
    too_bright = "too_bright"
    no_marker = "no_marker"
    """No scale marker found; the photo stays usable for reconstruction, not for measuring alone."""
    marker_too_small = "marker_too_small"
    """The marker is so small in the picture that the scale would be imprecise."""


REJECTING = frozenset(
    {QualityReason.unreadable, QualityReason.too_small, QualityReason.blurry, QualityReason.too_dark,
     QualityReason.too_bright}
)  # fmt: skip
"""Reasons that make a picture unusable for reconstruction; the others only advise."""


class MarkerSighting(Frozen):
    id: int
    side_px: float
    """Mean side length in pixels of the full-resolution image."""
    corners_px: list[list[float]]
    """Four corners (x, y) in full-resolution pixels, in ArUco order."""


class QualityFigures(Frozen):
    """What the gate measured, so a person can see why."""

    width: int
    height: int
    analysis_long_side: int
    """Long side, in pixels, of the image the figures below were computed on."""
    sharpness: float
    """Variance of the Laplacian over the whole image, at the analysis scale."""
    local_sharpness: float
    """75th percentile of the Laplacian variance over the tiles of the central region."""
    mean_intensity: float
    """Mean grey level, 0-255."""
    dark_fraction: float
    """Share of pixels at or below the dark clipping level."""
    bright_fraction: float
    """Share of pixels at or above the bright clipping level."""
    markers: list[MarkerSighting]
    seconds: float
    """Time the gate took for this picture."""


class QualityVerdict(Frozen):
    """Whether a picture is usable, why not, and what to do about it."""

    file: str
    accepted: bool
    """Usable for reconstruction (a missing marker alone does not make a picture unusable)."""
    reasons: list[QualityReason]
    guidance: list[str]
    """Sentences for the person holding the phone."""
    figures: QualityFigures | None
    """None when the file could not be decoded."""
