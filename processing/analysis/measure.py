"""Stage: the burn metrics from the fused surface probability.

    run(conf, surface_npz, mm_per_unit, units_per_mm, views, out_dir) -> out_dir/metrics.json

Geometry thresholds (ring distances, perimeter smoothing) are in mm. When the scale is unknown the
mesh is measured in "assumed mm" (model units / units_per_mm) only so those thresholds keep their
proportions; then no length, area or volume is reported, only the area in model units.
"""

from __future__ import annotations

import logging
from pathlib import Path

import msgspec
import numpy as np

from processing.analysis.burn_region import (
    SMOOTHING_MM,
    boundary_loops,
    burn_area_mm2,
    mesh_edges,
    per_face_burn_fraction,
    perimeter_mm,
    triangle_areas,
)
from processing.analysis.relief import UNCERTAIN_REFERENCE_MM, fit_reference, outward_at_burn, relief
from processing.reconstruction.views import View
from processing.stages import write_json
from schemas.analysis import BurnMetrics, ReferenceRecord
from schemas.base import Frozen
from schemas.config import AnalysisConfig
from schemas.errors import InvalidInput

log = logging.getLogger(__name__)

RESULT = "metrics.json"


class Measurement(Frozen):
    """What the metrics stage writes: the figures and the evidence they rest on."""

    metrics: BurnMetrics
    reference: ReferenceRecord | None
    burn_seen_by_3_fraction: float
    """Share of the burn area whose every corner at least `min_views_for_confidence` pictures see."""
    views_seeing_burn: int
    open_edges: int
    """Pieces of burn edge that run off the reconstructed surface (part of the burn may be missing)."""
    burn_at_surface_edge: bool
    """Burn reaches the border of the reconstructed surface or surface no picture saw: it may continue there."""
    perimeter_smoothing_mm: float
    view_agreement: float | None = None
    """Mean IoU of the views' burns on the surface (processing/analysis/fusion.py view_agreement)."""
    relief_note: str = ""
    """Why relief and volume are missing or uncertain, when they are."""


def agreement_of(data) -> float | None:
    """The surface stage's view agreement; None from a surface made before it was measured, or no pair."""
    if "view_agreement" not in data or np.isnan(data["view_agreement"]):
        return None
    return float(data["view_agreement"])


def burn_at_edge(faces: np.ndarray, q: np.ndarray) -> bool:
    """Whether a burn vertex lies on the mesh border or next to a vertex no picture saw."""
    burn = np.nan_to_num(q) >= 0.5
    edges = np.sort(mesh_edges(faces), axis=1)
    unique, counts = np.unique(edges, axis=0, return_counts=True)
    border = unique[counts == 1].ravel()
    if burn[border].any():
        return True
    unseen = np.isnan(q)
    touching = unseen[edges[:, 0]] & burn[edges[:, 1]] | unseen[edges[:, 1]] & burn[edges[:, 0]]
    return bool(touching.any())


def seen_fraction(vertices, faces, q, views_per_vertex, minimum: int) -> float:
    burnt = per_face_burn_fraction(vertices, faces, q) * triangle_areas(vertices[faces])
    well_seen = np.all(views_per_vertex[faces] >= minimum, axis=1)
    total = float(burnt.sum())
    return float(burnt[well_seen].sum() / total) if total > 0 else 0.0


def run(
    conf: AnalysisConfig,
    surface_npz: Path,
    mm_per_unit: float | None,
    units_per_mm: float,
    views: list[View],
    out_dir: Path,
) -> Path:
    data = np.load(surface_npz)
    scaled = bool(mm_per_unit)
    to_mm = 1.0 if scaled else 1.0 / units_per_mm  # the mesh is already in mm when scaled
    vertices, faces, q = data["vertices"] * to_mm, data["faces"], data["q"]
    area = burn_area_mm2(vertices, faces, q)
    loops = boundary_loops(vertices, faces, q)
    perimeter = perimeter_mm(loops)
    mm_views = [View(v.name, v.image_id, v.width, v.height, v.K, v.dist, v.R, v.t * to_mm) for v in views]
    reference, rel, relief_note = None, None, ""
    try:
        surface = fit_reference(
            vertices,
            faces,
            q,
            outward_at_burn(mm_views, vertices, q),
            ring_inner_mm=conf.ring_inner_mm,
            ring_outer_mm=conf.ring_outer_mm,
        )
        rel = relief(vertices, faces, q, surface)
        reference = ReferenceRecord(
            kind=surface.kind,
            ring_points=surface.ring_size,
            ring_rms_mm=round(surface.ring_rms_mm, 3) if scaled else None,
            holdout_mm=round(surface.holdout_mm, 3) if scaled and surface.holdout_mm is not None else None,
        )
        misfit = surface.holdout_mm if surface.holdout_mm is not None else surface.ring_rms_mm
        if scaled and misfit > UNCERTAIN_REFERENCE_MM:
            relief_note = (
                f"surface relief and volume are uncertain: the healthy skin around the burn is uneven, and "
                f"a smooth surface fitted to part of it misses the rest by {misfit:.1f} mm, so the level "
                "the skin would have over the burn is a guess; compare with examination"
            )
    except InvalidInput as exc:  # no healthy ring: the area still stands without relief
        relief_note = f"no surface relief or volume: {exc}"
        log.warning(relief_note)
    metrics = BurnMetrics(
        area_cm2=round(area / 100, 3) if scaled else None,
        perimeter_cm=round(perimeter.perimeter_mm / 10, 3) if scaled else None,
        relief_max_mm=round(rel.max_mm, 2) if scaled and rel else None,
        relief_mean_mm=round(rel.mean_mm, 2) if scaled and rel else None,
        raised_max_mm=round(rel.raised_max_mm, 2) if scaled and rel else None,
        volume_cm3=round(rel.volume_mm3 / 1000, 3) if scaled and rel else None,
        area_model_units2=round(area * units_per_mm**2, 6) if not scaled else None,
        burn_loops=perimeter.n_loops,
    )
    seen = data["view_sees_burn"] if "view_sees_burn" in data else np.ones(len(views), bool)
    result = Measurement(
        metrics=metrics,
        reference=reference,
        burn_seen_by_3_fraction=round(
            seen_fraction(vertices, faces, q, data["views_per_vertex"], conf.min_views_for_confidence), 4
        ),
        views_seeing_burn=int(seen.sum()),
        open_edges=sum(not loop.closed for loop in loops),
        burn_at_surface_edge=burn_at_edge(faces, q),
        perimeter_smoothing_mm=SMOOTHING_MM,
        view_agreement=agreement_of(data),
        relief_note=relief_note,
    )
    write_json(out_dir / RESULT, msgspec.to_builtins(result))
    return out_dir / RESULT
