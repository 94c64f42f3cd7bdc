"""Surface relief of the burn against the healthy skin around it: how far the wound lies below (or stands above)
where the skin would be. A geometric measure only; it is not the clinical burn depth (partial/full thickness).

Sign conventions: the reference frame's z axis points out of the body (towards the cameras). Depth is the
reference height minus the surface height along that z, so a sunken wound has positive depth and a blister or
oedema standing proud has negative depth (positive `raised_max_mm`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.spatial import cKDTree

from processing.analysis import skin_model
from processing.analysis.burn_region import (
    LEVEL,
    boundary_segments,
    burn_pieces,
    check_mesh,
    check_vertex_field,
    clip_above,
    triangle_areas,
)
from processing.reconstruction.views import View
from schemas.errors import InvalidInput

RING_INNER_MM = 3.0
RING_OUTER_MM = 15.0
MIN_RING_QUADRATIC = 30
"""Fewer ring vertices than this (5 per quadratic coefficient) and a robust quadratic is not trusted: plane."""
MIN_RING_QUARTIC = 300
"""From this many ring vertices (20 per quartic coefficient) the reference is a quartic: a limb's cross-section
is nearly circular, and a parabola fitted to a ring reaching 35 mm from the centre of a 40 mm-radius forearm
misses the circle by ~0.4 mm RMS, which biases the relief; a quartic follows it to ~0.07 mm (shared phantom p1)."""
MIN_RING_RIDGED = 600
"""From this many ring vertices (after thinning to 0.7 mm cells) a ridged model is also tried (skin_model)."""
RIDGED_GAIN = 0.7
"""The ridged model replaces the quartic only when it predicts unseen ring skin with under this fraction of the
quartic's error: on smooth limbs the two tie and the simpler quartic stays."""
UNCERTAIN_REFERENCE_MM = 0.2
"""A reference that predicts unseen ring skin worse than this (median error; ring RMS when the ring is too small
to test) makes relief and volume uncertain, and the result says so; a ridged model that does no better is not
believed. On the benchmark phantoms, references holding out at <= 0.14 mm gave relief within 0.5 mm and volume
within 16 % but for one foot with a skin bump leaning into the burn (+33 %); the one above it (0.34-0.62 mm, a
bump under the burn) gave volume -24 % or +17 % (docs/benchmarks.md)."""
MAX_RING_GAP_DEG = 90.0
"""If the ring leaves a wider angular gap around the burn (e.g. the burn runs off the mesh), a quadratic would
extrapolate its curvature over the burn from one side: plane."""
BOUNDARY_STEP_MM = 0.5


@dataclass(frozen=True)
class ReferenceSurface:
    """z = model(x, y) in a local frame: a plane, quadratic, quartic or ridged quartic (skin_model).

    The frame has its origin at the ring centroid and rows of `axes` = x, y, z (world), z pointing outwards.
    """

    model: skin_model.SkinModel
    origin: np.ndarray
    axes: np.ndarray
    ring_size: int
    ring_rms_mm: float
    holdout_mm: float | None = None
    """Median error predicting ring skin the model was not fitted to (skin_model.holdout_error_mm); None when
    the ring is too small to test."""

    @property
    def kind(self) -> skin_model.Kind:
        return self.model.kind

    def local(self, points: np.ndarray) -> np.ndarray:
        return (np.asarray(points, dtype=np.float64) - self.origin) @ self.axes.T

    def height(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return self.model.height(x, y)

    def depth(self, points: np.ndarray) -> np.ndarray:
        """Distance below the reference, positive where the surface is sunken: the height difference along the
        outward z, times cos of the reference's slope there, so it is measured along the reference's normal
        (on a limb's flank the vertical gap overstates the depth by 1 / cos slope)."""
        loc = self.local(points)
        x, y = loc[:, 0], loc[:, 1]
        e = 1e-3  # mm: central differences of a smooth polynomial
        hx = (self.height(x + e, y) - self.height(x - e, y)) / (2 * e)
        hy = (self.height(x, y + e) - self.height(x, y - e)) / (2 * e)
        return (self.height(x, y) - loc[:, 2]) / np.sqrt(1.0 + hx * hx + hy * hy)


@dataclass(frozen=True)
class Relief:
    """Relief over the burn region (mm, mm³); depth > 0 below the reference, raised_max_mm > 0 above it."""

    max_mm: float
    mean_mm: float
    volume_mm3: float
    raised_max_mm: float
    area_mm2: float


def outward_from_views(views: list[View], point: np.ndarray) -> np.ndarray:
    """Unit mean direction from a surface point to the camera centres: out of the body."""
    directions = np.array([v.centre - point for v in views], dtype=np.float64)
    mean = (directions / np.linalg.norm(directions, axis=1, keepdims=True)).sum(axis=0)
    return mean / np.linalg.norm(mean)


def outward_at_burn(views: list[View], vertices: np.ndarray, q: np.ndarray, level: float = LEVEL) -> np.ndarray:
    """Out of the body at the burn: from the burn's centroid (q >= level) towards the cameras."""
    return outward_from_views(views, vertices[np.nan_to_num(q) >= level].mean(axis=0))


def fit_reference(
    vertices: np.ndarray,
    faces: np.ndarray,
    q: np.ndarray,
    outward: np.ndarray,
    *,
    ring_inner_mm: float = RING_INNER_MM,
    ring_outer_mm: float = RING_OUTER_MM,
    level: float = LEVEL,
    kind: Literal["auto", "ridged", "quartic", "quadratic", "plane"] = "auto",
) -> ReferenceSurface:
    """Robust reference surface through the healthy ring around the burn (see module and constants)."""
    vertices, faces = check_mesh(vertices, faces)
    q = check_vertex_field(q, len(vertices))
    outward = np.asarray(outward, dtype=np.float64)
    if outward.shape != (3,) or not np.isclose(np.linalg.norm(outward), 1.0, atol=1e-3):
        raise InvalidInput(f"outward must be a unit 3-vector, got {outward}")
    if kind not in ("auto", *skin_model.POLY_COLUMNS, "ridged"):
        raise InvalidInput(f"kind must be auto, ridged, quartic, quadratic or plane, got {kind!r}")
    edge = _boundary_points(vertices, faces, q, level)
    ring = healthy_ring(vertices, q, edge, ring_inner_mm, ring_outer_mm, level)
    if len(ring) < 3:
        raise InvalidInput(
            f"only {len(ring)} healthy vertices lie {ring_inner_mm:g}-{ring_outer_mm:g} mm from the "
            "burn edge; the mesh must reach past the burn on healthy skin"
        )
    origin, axes = _frame(ring, outward)
    loc = (ring - origin) @ axes.T
    centre = (edge.mean(axis=0) - origin) @ axes.T
    wide = len(ring) >= MIN_RING_QUADRATIC and _max_gap_deg(loc[:, :2] - centre[:2]) <= MAX_RING_GAP_DEG
    model, holdout = _choose_model(loc, centre[:2], kind, wide)
    residual = model.height(loc[:, 0], loc[:, 1]) - loc[:, 2]
    return ReferenceSurface(
        model=model,
        origin=origin,
        axes=axes,
        ring_size=len(ring),
        ring_rms_mm=float(np.sqrt(np.mean(residual**2))),
        holdout_mm=holdout,
    )


def _choose_model(
    loc: np.ndarray, centre_xy: np.ndarray, kind: str, wide: bool
) -> tuple[skin_model.SkinModel, float | None]:
    """The requested model, or for "auto": a plane when the ring is thin or one-sided, else a quadratic or a
    quartic by ring size, replaced by the ridged model when it predicts unseen ring skin clearly better and well."""
    thinned = skin_model.thin(loc)
    testable = wide and len(thinned) >= MIN_RING_RIDGED
    if kind == "ridged":
        model = skin_model.fit_ridged(thinned)
    elif kind != "auto":
        model = skin_model.fit(kind, loc)
    elif not wide:
        model = skin_model.fit("plane", loc)
    else:
        model = skin_model.fit("quartic" if len(loc) >= MIN_RING_QUARTIC else "quadratic", loc)
    if not testable:
        return model, None
    holdout = skin_model.holdout_error_mm(thinned, centre_xy, model)
    if kind == "auto" and model.kind == "quartic":
        ridged = skin_model.fit_ridged(thinned)
        ridged_holdout = skin_model.holdout_error_mm(thinned, centre_xy, ridged)
        if ridged_holdout < min(RIDGED_GAIN * holdout, UNCERTAIN_REFERENCE_MM):
            return ridged, ridged_holdout
    return model, holdout


def healthy_ring(
    vertices: np.ndarray, q: np.ndarray, edge: np.ndarray, inner_mm: float, outer_mm: float, level: float = LEVEL
) -> np.ndarray:
    """Seen, unburnt vertices whose straight-line distance to the burn edge points lies in [inner_mm, outer_mm]."""
    distance, _ = cKDTree(edge).query(vertices)
    keep = np.isfinite(q) & (q < level) & (distance >= inner_mm) & (distance <= outer_mm)
    return vertices[keep]


def relief(
    vertices: np.ndarray, faces: np.ndarray, q: np.ndarray, reference: ReferenceSurface, level: float = LEVEL
) -> Relief:
    """Depth statistics over the burn (q >= level), integrating exactly over the burnt part of every face.

    max_mm: largest depth below the reference; mean_mm: area-weighted mean depth (signed); volume_mm3: integral
    of the positive depth (the hollow between reference and surface, a proxy for tissue loss); raised_max_mm:
    largest height above the reference. Depth is linear inside each face between its vertex values.
    """
    vertices, faces = check_mesh(vertices, faces)
    depth = reference.depth(vertices)
    pieces, _ = burn_pieces(vertices, faces, q, level, fields=depth[:, None])
    if len(pieces) == 0:
        raise InvalidInput(f"no part of the mesh has burn probability >= {level}; nothing to measure")
    areas = triangle_areas(pieces[:, :, :3])
    area = float(areas.sum())
    mean = float(np.sum(areas * pieces[:, :, 3].mean(axis=1)) / area) if area > 0 else 0.0
    sunken, _ = clip_above(pieces, pieces[:, :, 3])
    volume = float(np.sum(triangle_areas(sunken[:, :, :3]) * sunken[:, :, 3].mean(axis=1)))
    corner_depths = pieces[:, :, 3]
    return Relief(
        max_mm=float(corner_depths.max()),
        mean_mm=mean,
        volume_mm3=volume,
        raised_max_mm=float(-corner_depths.min()),
        area_mm2=area,
    )


def _boundary_points(vertices: np.ndarray, faces: np.ndarray, q: np.ndarray, level: float) -> np.ndarray:
    """Points along the burn edge, at most BOUNDARY_STEP_MM apart."""
    segments = boundary_segments(vertices, faces, q, level)
    if len(segments) == 0:
        raise InvalidInput(f"the burn has no edge on the mesh (no face where the probability crosses {level})")
    n = np.ceil(np.linalg.norm(segments[:, 1] - segments[:, 0], axis=1) / BOUNDARY_STEP_MM).astype(np.int64) + 1
    which = np.repeat(np.arange(len(segments)), n)
    t = (np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)) / np.maximum(np.repeat(n, n) - 1, 1)
    return segments[which, 0] + t[:, None] * (segments[which, 1] - segments[which, 0])


def _frame(points: np.ndarray, outward: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """PCA frame of the ring: centroid, rows x (largest spread), y, z (smallest spread, turned outward)."""
    origin = points.mean(axis=0)
    _, _, vt = np.linalg.svd(points - origin, full_matrices=False)
    x, z = vt[0], vt[2] if vt[2] @ outward >= 0 else -vt[2]
    return origin, np.stack([x, np.cross(z, x), z])


def _max_gap_deg(xy: np.ndarray) -> float:
    """Widest empty angular sector (degrees) of points around the origin."""
    angles = np.sort(np.arctan2(xy[:, 1], xy[:, 0]))
    gaps = np.diff(np.concatenate([angles, angles[:1] + 2 * math.pi]))
    return float(np.degrees(gaps.max()))
