"""Judging an SfM result: the failure a clinician can act on, and the quality indicators."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pycolmap

from processing.reconstruction.colmap_database import read_match_tables
from schemas.config import ReconstructionConfig
from schemas.errors import CaptureInsufficient
from schemas.reconstruction import FailureCode, SfmQuality

MIN_INLIERS = 15
MIN_TRI_ANGLE_DEG = 2.0
MIN_BASELINE_RATIO = 0.05
"""Widest distance between two camera positions over the median distance to the scene: below this the
pictures were taken from one spot (a bogus model of a pure rotation can still show wide angles)."""
_ROTATION_ONLY = {
    int(pycolmap.TwoViewGeometryConfiguration.PANORAMIC),
    int(pycolmap.TwoViewGeometryConfiguration.PLANAR_OR_PANORAMIC),
}
_UNUSABLE = {
    int(pycolmap.TwoViewGeometryConfiguration.UNDEFINED),
    int(pycolmap.TwoViewGeometryConfiguration.DEGENERATE),
    int(pycolmap.TwoViewGeometryConfiguration.WATERMARK),
}


@dataclass
class PairGraph:
    """Which pictures matched which, from the COLMAP database."""

    names: dict[int, str]
    matches: dict[tuple[int, int], int]
    verified: dict[tuple[int, int], tuple[int, int]]

    def edges(self) -> list[tuple[int, int]]:
        return [p for p, (rows, config) in self.verified.items() if rows >= MIN_INLIERS and config not in _UNUSABLE]

    def components(self) -> list[list[str]]:
        parent = {i: i for i in self.names}

        def root(i: int) -> int:
            while parent[i] != i:
                parent[i] = parent[parent[i]]
                i = parent[i]
            return i

        for a, b in self.edges():
            parent[root(a)] = root(b)
        groups: dict[int, list[str]] = {}
        for i, name in self.names.items():
            groups.setdefault(root(i), []).append(name)
        return sorted((sorted(g) for g in groups.values()), key=len, reverse=True)

    def rotation_only_share(self) -> float:
        edges = self.edges()
        if not edges:
            return 0.0
        return sum(self.verified[p][1] in _ROTATION_ONLY for p in edges) / len(edges)


def pair_graph(database: Path) -> PairGraph:
    """Which pictures matched which, from the COLMAP database at `database`."""
    tables = read_match_tables(database)
    return PairGraph(tables.names, tables.matches, tables.verified)


def check_model(
    conf: ReconstructionConfig, models: list[pycolmap.Reconstruction], names: list[str], graph: PairGraph
) -> tuple[pycolmap.Reconstruction, float]:
    """The largest model and its median triangulation angle, or CaptureInsufficient saying why the
    pictures cannot be measured."""
    needed = max(3, math.ceil(conf.min_registered_fraction * len(names)))
    placed = models[0].num_reg_images() if models else 0
    if placed < needed:
        # Separate groups only matter when they stop the main one from being big enough; a few
        # stray pictures beside a good set are simply left out (and listed in the quality record).
        groups = [g for g in graph.components() if len(g) >= 3]
        if len(groups) >= 2:
            raise CaptureInsufficient(
                f"the pictures show {len(groups)} different scenes that share nothing "
                f"({_list(groups[0])} versus {_list(groups[1])}); keep only the pictures of this burn",
                code=FailureCode.mixed_scenes,
            )
        if graph.rotation_only_share() > 0.5:
            raise CaptureInsufficient(
                "the pictures look as if taken from about the same spot (or show only a flat area), so no "
                "depth can be seen; retake walking around the burn (about a quarter circle), keeping it in the centre",
                code=FailureCode.degenerate_capture,
            )
        raise CaptureInsufficient(
            f"only {placed} of {len(names)} pictures could be placed; retake walking around the burn, "
            "with the burn and the marker in every picture and plenty of overlap between pictures",
            code=FailureCode.too_few_placed,
        )
    angle = median_triangulation_angle(models[0])
    rotation_only = graph.rotation_only_share() > 0.5
    if (
        angle < MIN_TRI_ANGLE_DEG
        or baseline_ratio(models[0]) < MIN_BASELINE_RATIO
        or (rotation_only and angle < 2 * MIN_TRI_ANGLE_DEG)
    ):
        raise CaptureInsufficient(
            f"the pictures were taken from nearly one spot (median viewing angle {angle:.1f} degrees); "
            "retake walking around the burn so it is seen from clearly different directions",
            code=FailureCode.degenerate_capture,
        )
    return models[0], angle


def baseline_ratio(model: pycolmap.Reconstruction) -> float:
    centres = np.array([model.images[i].projection_center() for i in model.reg_image_ids()])
    if len(centres) < 2 or not model.num_points3D():
        return 0.0
    widest = float(np.max(np.linalg.norm(centres[:, None] - centres[None], axis=2)))
    points = np.array([p.xyz for p in model.points3D.values()])
    depth = float(np.median(np.linalg.norm(points - centres.mean(axis=0), axis=1)))
    return widest / max(depth, 1e-12)


def _list(names: list[str]) -> str:
    return ", ".join(names[:4]) + (f" and {len(names) - 4} more" if len(names) > 4 else "")


def median_triangulation_angle(model: pycolmap.Reconstruction, sample: int = 3000) -> float:
    centres = {i: model.images[i].projection_center() for i in model.reg_image_ids()}
    rng = np.random.default_rng(0)
    ids = list(model.point3D_ids())
    if not ids:
        return 0.0
    angles = []
    for pid in rng.choice(ids, size=min(sample, len(ids)), replace=False):
        point = model.points3D[int(pid)]
        rays = np.array([centres[e.image_id] - point.xyz for e in point.track.elements])
        rays /= np.linalg.norm(rays, axis=1, keepdims=True)
        cosines = np.clip(rays @ rays.T, -1.0, 1.0)
        angles.append(math.degrees(math.acos(cosines.min())))
    return float(np.median(angles))


def quality_record(
    model: pycolmap.Reconstruction,
    models: list[pycolmap.Reconstruction],
    names: list[str],
    graph: PairGraph,
    matching: str,
    angle: float,
) -> SfmQuality:
    errors = np.array([p.error for p in model.points3D.values()]) if model.num_points3D() else np.zeros(1)
    registered = {model.images[i].name for i in model.reg_image_ids()}
    matched = {p: n for p, n in graph.matches.items() if n > 0}
    ratios = [graph.verified.get(p, (0, 0))[0] / n for p, n in matched.items()]
    camera = next(iter(model.cameras.values()))
    return SfmQuality(
        matching=matching,
        images_used=len(names),
        images_registered=len(registered),
        unregistered=sorted(set(names) - registered),
        image_pairs_matched=len(matched),
        image_pairs_verified=len(graph.edges()),
        mean_matches_per_pair=round(float(np.mean(list(matched.values()))) if matched else 0.0, 1),
        mean_inlier_ratio=round(float(np.mean(ratios)) if ratios else 0.0, 3),
        mean_reprojection_error_px=round(float(errors.mean()), 3),
        median_reprojection_error_px=round(float(np.median(errors)), 3),
        points=model.num_points3D(),
        mean_points_per_image=round(model.compute_mean_observations_per_reg_image(), 1),
        mean_track_length=round(model.compute_mean_track_length(), 2),
        models_found=len(models),
        focal_px=round(float(camera.mean_focal_length()), 2),
        median_triangulation_angle_deg=round(angle, 2),
    )
