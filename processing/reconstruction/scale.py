"""Stage 2: metric scale from the printed marker (or the clinician's ruler points), and the output frame."""

from __future__ import annotations

import logging
import math
from pathlib import Path

import numpy as np

from processing.capture.marker import find_markers
from processing.reconstruction.marker_edges import linear_intensity, refine_quad
from processing.reconstruction.triangulate import triangulate
from processing.reconstruction.views import View, load_views, read_gray, read_model
from processing.stages import write_json
from schemas.base import counted
from schemas.config import ReconstructionConfig
from schemas.errors import CaptureInsufficient
from schemas.reconstruction import FailureCode, RulerPoints, ScaleEstimate, ScaleResult, ScaleSource

log = logging.getLogger(__name__)

RESULT = "scale.json"
EDGES = ((0, 1, 1.0), (1, 2, 1.0), (2, 3, 1.0), (3, 0, 1.0), (0, 2, math.sqrt(2)), (1, 3, math.sqrt(2)))
"""Corner pairs of one marker and their length in marker sides: four sides and two diagonals."""
SCALE_FLOOR = 0.003
"""Smallest relative scale uncertainty ever reported (1 sigma)."""
RULER_MAX_PX = 5.0
"""A ruler click further than this from where the other clicks put the point is a different spot."""


def run(
    conf: ReconstructionConfig, model_dir: Path, images_dir: Path, out_dir: Path, ruler: RulerPoints | None = None
) -> Path:
    """Write out_dir/scale.json: the scale with its evidence and the model -> output transform."""
    views = load_views(read_model(model_dir))
    corners, detected = marker_corners(conf, views, images_dir)
    result = from_marker(conf, corners, views, detected)
    if result.estimate.source is ScaleSource.none and ruler is not None:
        result = from_ruler(ruler, views, result.estimate.note)
    log.info("scale: %s (%s)", result.estimate.source, result.estimate.note)
    return write_json(out_dir / RESULT, result)


def marker_corners(
    conf: ReconstructionConfig, views: list[View], images_dir: Path
) -> tuple[dict[int, list[list[tuple[View, np.ndarray]]]], int]:
    """Per marker id, per corner (ArUco order): the (view, undistorted pixel) sightings whose edges
    could be measured; and in how many pictures a marker was detected at all."""
    found: dict[int, list[list[tuple[View, np.ndarray]]]] = {}
    detected = 0
    for view in views:
        gray = read_gray(images_dir / view.name)
        linear = linear_intensity(gray)
        sightings = find_markers(gray, 1.0, conf.marker_dictionary)
        detected += bool(sightings)
        for sighting in sightings:
            quad = refine_quad(linear, np.array(sighting.corners_px), view.undistort_points)
            if quad is None:
                continue
            slots = found.setdefault(sighting.id, [[], [], [], []])
            for k in range(4):
                slots[k].append((view, quad[k]))
    return found, detected


def from_marker(
    conf: ReconstructionConfig,
    found: dict[int, list[list[tuple[View, np.ndarray]]]],
    views: list[View],
    detected: int = 0,
) -> ScaleResult:
    corners: dict[int, np.ndarray] = {}
    residuals: list[float] = []
    for marker_id, slots in found.items():
        if min(len(s) for s in slots) < conf.marker_min_views:
            continue
        quad = []
        for sightings in slots:
            point, errors, kept = triangulate([v for v, _ in sightings], [p for _, p in sightings])
            residuals += [errors[i] for i in kept]
            quad.append(point)
        corners[marker_id] = np.array(quad)
    seen_in = len({v.name for slots in found.values() for s in slots for v, _ in s})
    if not corners:
        if found:
            note = f"the marker was measurable in too few placed pictures (needs {conf.marker_min_views})"
        elif detected:
            note = (
                f"the marker was seen in {detected} pictures but its edges could not be measured "
                "(glare, cut off by the picture's edge, or too small)"
            )
        else:
            note = "no scale marker was found"
        note += "; sizes are in model units only"
        return ScaleResult(ScaleEstimate(ScaleSource.none, views_with_marker=seen_in, note=note), _identity())
    estimates, per_marker = [], []
    for quad in corners.values():
        mine = [conf.marker_side_mm * factor / float(np.linalg.norm(quad[i] - quad[j])) for i, j, factor in EDGES]
        estimates += mine
        per_marker.append(float(np.median(mine)))
    values = np.array(estimates)
    median = float(np.median(values))
    mad = 1.4826 * float(np.median(np.abs(values - median)))
    keep = np.abs(values - median) <= max(3 * mad, 0.002 * median)
    scale = float(np.median(values[keep]))
    # Judged on every edge, before rejection: two bad edges of six must not vanish as "outliers".
    spread = 1.4826 * float(np.median(np.abs(values - scale))) / scale
    rejected = int((~keep).sum())
    # The six edges of one marker share four corners, so markers (not edges) are the independent
    # measurements; the floor covers what no spread shows (print scale, SfM drift): on the phantoms
    # the marker scale was off by up to 0.2 %.
    between = float(np.std(per_marker, ddof=1)) / math.sqrt(len(per_marker)) / scale if len(per_marker) > 1 else 0.0
    estimate = ScaleEstimate(
        ScaleSource.marker,
        mm_per_unit=scale,
        relative_uncertainty=round(max(SCALE_FLOOR, between), 5),
        relative_spread=round(spread, 5),
        edges_used=int(keep.sum()),
        edges_rejected=rejected,
        marker_ids=sorted(corners),
        views_with_marker=seen_in,
        mean_corner_reprojection_px=round(float(np.mean(residuals)), 3),
        note=f"{counted(len(corners), 'marker')}, {int(keep.sum())} edges and diagonals",
    )
    model_corners = {str(k): v.tolist() for k, v in corners.items()}
    if spread > conf.max_scale_spread or rejected > len(values) // 3:
        untrusted = ScaleEstimate(
            ScaleSource.none,
            views_with_marker=seen_in,
            relative_spread=round(spread, 5),
            note=f"the marker's edges disagree ({100 * spread:.1f} % spread, {rejected} of {len(values)} edges off; "
            "bent, creased or partly hidden marker?); "
            "the scale is not trusted and sizes stay in model units",
        )
        return ScaleResult(untrusted, _identity(), model_corners)
    return ScaleResult(estimate, _marker_frame(np.vstack(list(corners.values())), scale, views), model_corners)


def from_ruler(ruler: RulerPoints, views: list[View], why_not_marker: str) -> ScaleResult:
    by_name = {v.name: v for v in views}
    marks = [m for m in ruler.marks if m.image in by_name]
    if len(marks) < 2:
        raise CaptureInsufficient(
            f"the ruler points are marked in {counted(len(marks), 'placed picture')}; mark both points in at least two",
            code=FailureCode.bad_ruler,
        )
    chosen = [by_name[m.image] for m in marks]
    points, errors = [], []
    for key in ("a", "b"):
        pixels = [chosen[i].undistort_points(np.array([getattr(m, key)]))[0] for i, m in enumerate(marks)]
        point, err, _ = triangulate(chosen, pixels)
        off = [m.image for m, e in zip(marks, err, strict=True) if e > RULER_MAX_PX]
        if off:
            raise CaptureInsufficient(
                f"ruler point {key.upper()} in {', '.join(off)} does not match the other pictures "
                f"(off by up to {np.max(err):.0f} pixels); mark the same spot in each picture",
                code=FailureCode.bad_ruler,
            )
        points.append(point)
        errors += list(err)
    length = float(np.linalg.norm(points[0] - points[1]))
    scale = ruler.distance_mm / length
    # A click is good to about its reprojection error; both ends contribute.
    depth = float(np.median([np.linalg.norm(v.centre - points[0]) for v in chosen])) * scale
    focal = float(np.median([v.K[0, 0] for v in chosen]))
    relative = math.sqrt(2) * max(float(np.mean(errors)), 0.5) * depth / focal / ruler.distance_mm
    checked = len(marks) >= 3
    if not checked:
        relative *= 3  # two pictures always agree on some point: a mis-click cannot be seen, so widen
    estimate = ScaleEstimate(
        ScaleSource.ruler,
        mm_per_unit=scale,
        relative_uncertainty=round(max(SCALE_FLOOR, relative), 5),
        views_with_marker=0,
        mean_corner_reprojection_px=round(float(np.mean(errors)), 3),
        note=f"ruler points marked in {len(marks)} pictures"
        + ("" if checked else " (two pictures cannot cross-check a click; mark a third to confirm)")
        + f" ({why_not_marker})",
    )
    transform = np.eye(4)
    transform[:3, :3] *= scale
    return ScaleResult(estimate, transform.tolist())


def _marker_frame(points: np.ndarray, scale: float, views: list[View]) -> list[list[float]]:
    """Similarity to mm with the marker centre at the origin, its plane z = 0 and z towards the cameras."""
    centre = points.mean(axis=0)
    _, _, vt = np.linalg.svd(points - centre)
    z = vt[2]
    if np.dot(np.mean([v.centre for v in views], axis=0) - centre, z) < 0:
        z = -z
    x = points[1] - points[0]
    x = x - np.dot(x, z) * z
    x /= np.linalg.norm(x)
    rotation = np.array([x, np.cross(z, x), z])
    transform = np.eye(4)
    transform[:3, :3] = scale * rotation
    transform[:3, 3] = -scale * rotation @ centre
    return transform.tolist()


def _identity() -> list[list[float]]:
    return np.eye(4).tolist()
