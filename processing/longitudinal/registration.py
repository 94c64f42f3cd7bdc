"""Registering a follow-up visit's surface to the baseline visit's, on healthy skin only.

The printed marker is laid down afresh at every visit, so each analysis has its own frame. The limb's skin
around the burn is the only thing common to two visits: the burn shrinks and flattens, the drape or table under
the limb does not move with it. So both surfaces are cut down to the skin above the dominant plane (the drape),
outside the burn and a margin, in a ring around it; then

1. coarse: FPFH features with a skin-texture descriptor, and RANSAC (several seeded tries, each refined by ICP;
   the one whose skin texture agrees best wins: a limb is nearly a cylinder, and on shape alone single tries
   land on a turned or slid copy of it);
2. fine: the skin ring is re-cut around the baseline's burn in both visits (the same patch of skin), leaving out
   both burns, and ICP (point-to-plane) runs again.

Everything is in mm: only scaled analyses are registered.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, replace
from functools import cached_property
from pathlib import Path

import numpy as np
import open3d as o3d
from scipy.spatial import cKDTree

from schemas.config import TrackingConfig
from schemas.errors import CaptureInsufficient, InvalidInput
from schemas.longitudinal import Registration
from schemas.reconstruction import FailureCode

log = logging.getLogger(__name__)
reg = o3d.pipelines.registration

AGREE_MM = 1.0
"""Two tries agree when their alignments put the skin within this RMS distance of each other."""
RIVAL_SHARE = 0.9
"""A disagreeing try that matches at least this share of the winner's skin makes the choice ambiguous."""


@dataclass(frozen=True)
class Surface:
    """One visit's reconstructed surface (mm) and its burn."""

    vertices: np.ndarray
    normals: np.ndarray
    burn: np.ndarray
    """Per vertex: inside the burn (fused probability >= 0.5)."""
    grey: np.ndarray | None = None
    """Per vertex: grey level 0..1 of the mesh's colours (None when the mesh carries none)."""

    @property
    def burn_points(self) -> np.ndarray:
        return self.vertices[self.burn]

    @property
    def burn_centre(self) -> np.ndarray:
        return self.burn_points.mean(axis=0)

    @property
    def burn_extent_mm(self) -> float:
        """How far the burn reaches from its centre (95th percentile, so a stray vertex does not count)."""
        return float(np.percentile(np.linalg.norm(self.burn_points - self.burn_centre, axis=1), 95))


def load_surface(npz: Path, mesh_ply: Path | None = None) -> Surface:
    """The surface written by the analysis's surface stage (surface/burn_surface.npz), with the skin's grey
    levels from the reconstructed mesh (mesh/surface.ply, the same vertices) when given."""
    try:
        data = np.load(npz)
        vertices, faces, q = data["vertices"], data["faces"], data["q"]
    except (OSError, KeyError, ValueError) as exc:
        raise InvalidInput(f"{npz} is missing or unreadable ({exc}); run the analysis again") from exc
    burn = np.nan_to_num(q) >= 0.5
    if not burn.any():
        raise CaptureInsufficient(f"{npz} holds no burn to register around", code=FailureCode.no_burn)
    mesh = o3d.geometry.TriangleMesh(
        o3d.utility.Vector3dVector(vertices.astype(np.float64)), o3d.utility.Vector3iVector(faces.astype(np.int32))
    )
    mesh.compute_vertex_normals()
    grey = None
    if mesh_ply is not None and mesh_ply.is_file():
        colours = np.asarray(o3d.io.read_triangle_mesh(str(mesh_ply)).vertex_colors)
        if len(colours) == len(vertices):
            grey = colours @ np.array([0.299, 0.587, 0.114])
    return Surface(
        vertices=vertices.astype(np.float64), normals=np.asarray(mesh.vertex_normals).copy(), burn=burn, grey=grey
    )


def off_plane(conf: TrackingConfig, surface: Surface) -> np.ndarray:
    """Per vertex: not part of the dominant plane (the drape or table) nor lower than the clearance above it, on
    the side where most of the burn lies. When most of the burn lies on the dominant plane (flat skin filling the
    view), no plane is removed."""
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(surface.vertices)).voxel_down_sample(2.0)
    if len(cloud.points) < 50:
        return np.ones(len(surface.vertices), bool)
    o3d.utility.random.seed(conf.seed)
    plane, _ = cloud.segment_plane(conf.plane_distance_mm, 3, 1000)
    height = surface.vertices @ np.array(plane[:3]) + float(plane[3])
    burn_height = float(np.median(height[surface.burn]))
    if abs(burn_height) < conf.plane_clearance_mm + conf.burn_margin_mm:
        log.info("the burn lies on the dominant plane: flat skin, no drape removed")
        return np.ones(len(surface.vertices), bool)
    return height * math.copysign(1.0, burn_height) > conf.plane_clearance_mm


def on_skin(surface: Surface, usable: np.ndarray, name: str) -> Surface:
    """The surface with its burn cut to the limb: a speck the model marked on the drape is no burn to register
    around (it would move the burn's centre and the skin ring)."""
    burn = surface.burn & usable
    if not burn.any():
        raise CaptureInsufficient(
            f"no burn on the limb in the {name}'s surface (only on the drape) to register around",
            code=FailureCode.no_burn,
        )
    return replace(surface, burn=burn)


def skin_mask(
    conf: TrackingConfig,
    surface: Surface,
    around: np.ndarray,
    reach_mm: float,
    avoid: list[np.ndarray],
    usable: np.ndarray,
) -> np.ndarray:
    """Per vertex, healthy skin: usable, within `reach_mm` of the points `around`, and farther than the margin from
    every point set in `avoid` (burns, in this surface's frame)."""
    keep = usable.copy()
    near, _ = cKDTree(around).query(surface.vertices[keep], distance_upper_bound=reach_mm)
    keep[keep] = np.isfinite(near)
    for burn in avoid:
        gap, _ = cKDTree(burn).query(surface.vertices[keep])
        keep[keep] = gap > conf.burn_margin_mm
    return keep


@dataclass(frozen=True)
class Skin:
    """Healthy-skin points of one visit thinned on a grid, with normals, and the skin's texture: grey level minus
    its local mean, in standard deviations (None without colours)."""

    cloud: o3d.geometry.PointCloud
    texture: np.ndarray | None

    @property
    def points(self) -> np.ndarray:
        return np.asarray(self.cloud.points)

    @cached_property
    def smooth_texture(self) -> np.ndarray | None:
        """The texture averaged over its AGREEMENT_NEIGHBOURS nearest points, in standard deviations."""
        if self.texture is None or len(self.texture) <= AGREEMENT_NEIGHBOURS:
            return self.texture
        _, near = cKDTree(self.points).query(self.points, k=AGREEMENT_NEIGHBOURS)
        smooth = self.texture[near].mean(axis=1)
        return smooth / max(float(smooth.std()), 1e-6)


TEXTURE_NEIGHBOURS = 48
"""The local mean that is taken off each grey level: over this many nearest points (a disc of ~2 mm radius at
0.5 mm spacing), so that lighting drops out and freckles, hair and pores stay."""
AGREEMENT_NEIGHBOURS = 16
"""The texture agreement compares the texture averaged over this many nearest points (~1 mm radius at 0.5 mm
spacing) and matches points within AGREEMENT_MATCH_MM. Point by point, the finest detail decorrelates within a
fraction of a mm: on the test's forearm series a right alignment (0.1-0.7 mm from the truth, a limb slides
along its axis) read 0.07-0.14, where 0.5 mm along the axis read 0.46-0.65; averaged it reads 0.39-0.76 and
wrong alignments (6-19 mm off) stay within +-0.13."""
AGREEMENT_MATCH_MM = 1.5


def skin_cloud(surface: Surface, keep: np.ndarray, voxel: float) -> Skin:
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(surface.vertices[keep]))
    cloud.normals = o3d.utility.Vector3dVector(surface.normals[keep])
    if surface.grey is not None:
        cloud.colors = o3d.utility.Vector3dVector(np.repeat(surface.grey[keep, None], 3, axis=1))
    cloud = cloud.voxel_down_sample(voxel)
    cloud.normalize_normals()
    if surface.grey is None or len(cloud.points) <= TEXTURE_NEIGHBOURS:
        return Skin(cloud, None)
    points, grey = np.asarray(cloud.points), np.asarray(cloud.colors)[:, 0]
    _, near = cKDTree(points).query(points, k=TEXTURE_NEIGHBOURS)
    detail = grey - grey[near].mean(axis=1)
    return Skin(cloud, detail / max(float(detail.std()), 1e-6))


def texture_agreement(transform: np.ndarray, source: Skin, target: Skin) -> float | None:
    """Correlation of the (smoothed) skin texture between matched points once `source` is moved by `transform`:
    near 0 for a wrong alignment, whatever the geometry says; None without texture."""
    if source.smooth_texture is None or target.smooth_texture is None:
        return None
    gap, nearest = cKDTree(target.points).query(
        _apply(transform, source.points), distance_upper_bound=AGREEMENT_MATCH_MM
    )
    matched = np.isfinite(gap)
    if matched.sum() < 50:
        return 0.0
    correlation = float(np.corrcoef(source.smooth_texture[matched], target.smooth_texture[nearest[matched]])[0, 1])
    return correlation if math.isfinite(correlation) else 0.0  # a flat texture (no detail) confirms nothing


TEXTURE_RINGS_MM = (0.0, 1.5, 3.0, 4.5, 6.0)
"""Rings around each point over which the skin texture's mean and spread make its texture descriptor."""


def features(conf: TrackingConfig, skin: Skin) -> o3d.pipelines.registration.Feature:
    """FPFH (the local shape), and, with colours, a texture descriptor: the mean and spread of the skin texture in
    rings around the point (turning the skin does not change it). A limb is nearly a cylinder, whose shape looks
    alike everywhere; freckles, hair and pores do not. The texture part is scaled to the FPFH's typical length
    times conf.texture_feature_weight."""
    fpfh = reg.compute_fpfh_feature(
        skin.cloud, o3d.geometry.KDTreeSearchParamHybrid(radius=conf.fpfh_radius_mm, max_nn=100)
    )
    if skin.texture is None or conf.texture_feature_weight == 0:
        return fpfh
    gaps, near = cKDTree(skin.points).query(skin.points, k=80, distance_upper_bound=TEXTURE_RINGS_MM[-1])
    texture = np.append(skin.texture, 0.0)[near]  # missing neighbours (index n) read 0 and are masked out below
    rows = []
    for inner, outer in zip(TEXTURE_RINGS_MM[:-1], TEXTURE_RINGS_MM[1:], strict=True):
        in_ring = (gaps >= inner) & (gaps < outer)
        count = np.maximum(in_ring.sum(axis=1), 1)
        mean = (texture * in_ring).sum(axis=1) / count
        spread = np.sqrt(np.maximum((texture**2 * in_ring).sum(axis=1) / count - mean**2, 0.0))
        rows += [mean, spread]
    shape, described = np.asarray(fpfh.data), np.array(rows)
    scale = np.median(np.linalg.norm(shape, axis=0)) / max(float(np.median(np.linalg.norm(described, axis=0))), 1e-9)
    combined = reg.Feature()
    combined.data = np.vstack([shape, conf.texture_feature_weight * scale * described])
    return combined


def icp(
    conf: TrackingConfig, source: o3d.geometry.PointCloud, target: o3d.geometry.PointCloud, start: np.ndarray
) -> o3d.pipelines.registration.RegistrationResult:
    """ICP rounds with shrinking correspondence distances (conf.icp_distances_mm), from `start`."""
    estimation = (
        reg.TransformationEstimationPointToPlane()
        if conf.point_to_plane
        else reg.TransformationEstimationPointToPoint()
    )
    result, transform = None, start
    for distance in conf.icp_distances_mm:
        result = reg.registration_icp(
            source, target, distance, transform, estimation, reg.ICPConvergenceCriteria(max_iteration=60)
        )
        transform = result.transformation
    return result


def surface_rmse(transform: np.ndarray, source: Skin, target: Skin, distance: float) -> float:
    """RMS of the distances from the moved `source` points to the `target` surface (along its normals) over the
    points matched within `distance`: how far the two skins lie apart, without the spacing of the samples that a
    point-to-point RMSE adds (about 0.2 mm at 0.5 mm spacing)."""
    moved = _apply(transform, source.points)
    gap, nearest = cKDTree(target.points).query(moved, distance_upper_bound=distance)
    matched = np.isfinite(gap)
    if not matched.any():
        return math.inf
    normals = np.asarray(target.cloud.normals)[nearest[matched]]
    along = np.sum((moved[matched] - target.points[nearest[matched]]) * normals, axis=1)
    return float(np.sqrt(np.mean(along**2)))


def _apply(transform: np.ndarray, points: np.ndarray) -> np.ndarray:
    return points @ transform[:3, :3].T + transform[:3, 3]


def _rms_apart(a: np.ndarray, b: np.ndarray, points: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum((_apply(a, points) - _apply(b, points)) ** 2, axis=1))))


@dataclass(frozen=True)
class _Try:
    seed: int
    transform: np.ndarray
    overlap: float
    texture: float | None

    @property
    def score(self) -> tuple[float, float]:
        """Texture agreement first (geometry alone cannot tell a limb from its turned copy), then overlap."""
        return (round(self.texture, 2) if self.texture is not None else 0.0, round(self.overlap, 3))


def coarse_tries(conf: TrackingConfig, source: Skin, target: Skin, fine_source: Skin, fine_target: Skin) -> list[_Try]:
    """Seeded FPFH + RANSAC tries, each refined by ICP on the finer clouds; best first."""
    source_features, target_features = features(conf, source), features(conf, target)
    tries = []
    for k in range(conf.ransac_tries):
        o3d.utility.random.seed(conf.seed + k)
        coarse = reg.registration_ransac_based_on_feature_matching(
            source.cloud,
            target.cloud,
            source_features,
            target_features,
            True,
            conf.ransac_distance_mm,
            reg.TransformationEstimationPointToPoint(False),
            3,
            [
                reg.CorrespondenceCheckerBasedOnEdgeLength(0.9),
                reg.CorrespondenceCheckerBasedOnDistance(conf.ransac_distance_mm),
            ],
            reg.RANSACConvergenceCriteria(conf.ransac_iterations, 0.999),
        )
        fine = icp(conf, fine_source.cloud, fine_target.cloud, coarse.transformation)
        transform = np.array(fine.transformation)
        texture = texture_agreement(transform, fine_source, fine_target)
        tries.append(_Try(conf.seed + k, transform, fine.fitness, texture))
    return sorted(tries, key=lambda t: t.score, reverse=True)


def register(conf: TrackingConfig, baseline: Surface, follow: Surface) -> Registration:
    """The rigid transform taking `follow` (a later visit) onto `baseline`, with its quality and warnings."""
    started = time.perf_counter()
    usable_base, usable_follow = off_plane(conf, baseline), off_plane(conf, follow)
    baseline, follow = on_skin(baseline, usable_base, "first visit"), on_skin(follow, usable_follow, "this visit")
    reach = baseline.burn_extent_mm + conf.burn_margin_mm + conf.skin_ring_mm

    # Coarse: around each visit's own burn centre, as far as the baseline's burn reaches plus the ring (the burn
    # contracts towards its centre, so both discs cover about the same skin).
    disc_base = skin_mask(conf, baseline, baseline.burn_centre[None], reach, [baseline.burn_points], usable_base)
    disc_follow = skin_mask(conf, follow, follow.burn_centre[None], reach, [follow.burn_points], usable_follow)
    coarse_base, coarse_follow = (
        skin_cloud(baseline, disc_base, conf.voxel_mm),
        skin_cloud(follow, disc_follow, conf.voxel_mm),
    )
    for name, skin in (("first visit", coarse_base), ("this visit", coarse_follow)):
        if len(skin.points) < conf.min_points:
            raise CaptureInsufficient(
                f"too little healthy skin around the burn on the {name}'s surface ({len(skin.points)} points at "
                f"{conf.voxel_mm:g} mm, {conf.min_points} needed) to register the visits: photograph more skin "
                "around the burn",
                code=FailureCode.too_few_views,
            )
    tries = coarse_tries(
        conf,
        coarse_follow,
        coarse_base,
        skin_cloud(follow, disc_follow, conf.fine_voxel_mm),
        skin_cloud(baseline, disc_base, conf.fine_voxel_mm),
    )
    best = tries[0]

    # Fine: the same skin ring in both visits, around the baseline's burn, leaving out both burns.
    base_burn_in_follow = _apply(np.linalg.inv(best.transform), baseline.burn_points)
    follow_burn_in_base = _apply(best.transform, follow.burn_points)
    ring = conf.burn_margin_mm + conf.skin_ring_mm
    fine_base = skin_cloud(
        baseline,
        skin_mask(conf, baseline, baseline.burn_points, ring, [baseline.burn_points, follow_burn_in_base], usable_base),
        conf.fine_voxel_mm,
    )
    fine_follow = skin_cloud(
        follow,
        skin_mask(conf, follow, base_burn_in_follow, ring, [follow.burn_points, base_burn_in_follow], usable_follow),
        conf.fine_voxel_mm,
    )
    if min(len(fine_base.points), len(fine_follow.points)) < conf.min_points:
        raise CaptureInsufficient(
            "the two visits' surfaces share too little healthy skin around the burn to register them: photograph "
            "more skin around the burn at each visit",
            code=FailureCode.too_few_views,
        )
    result = icp(conf, fine_follow.cloud, fine_base.cloud, best.transform)
    transform = np.array(result.transformation)
    texture = texture_agreement(transform, fine_follow, fine_base)
    rmse = surface_rmse(transform, fine_follow, fine_base, conf.icp_distances_mm[-1])

    skin = fine_follow.points
    apart = [_rms_apart(t.transform, best.transform, skin) for t in tries]
    agreeing = sum(a <= AGREE_MM for a in apart)
    rivals = [
        t
        for t, a in zip(tries, apart, strict=True)
        if a > AGREE_MM and t.score[0] >= RIVAL_SHARE * best.score[0] and t.score[1] >= RIVAL_SHARE * best.score[1]
    ]
    shift = float(np.linalg.norm(_apply(transform, follow.burn_centre[None])[0] - baseline.burn_centre))
    warnings = []
    if rmse > conf.max_rmse_mm:
        warnings.append(
            f"the healthy skin of the two visits matches poorly (RMSE {rmse:.2f} mm, limit {conf.max_rmse_mm:g} mm)"
        )
    if result.fitness < conf.min_overlap:
        warnings.append(
            f"only {100 * result.fitness:.0f} % of this visit's healthy skin matched the first visit's "
            f"(limit {100 * conf.min_overlap:.0f} %)"
        )
    if texture is not None and texture < conf.min_texture_agreement:
        warnings.append(
            f"the skin's texture (freckles, hair, pores) does not confirm the alignment (correlation "
            f"{texture:.2f}, limit {conf.min_texture_agreement:g})"
        )
    if rivals:
        warnings.append(f"RANSAC is unstable: {len(rivals)} other alignment(s) fit nearly as well")
    elif conf.ransac_tries > 1 and agreeing < 2:
        warnings.append(f"RANSAC is unstable: only 1 of {conf.ransac_tries} tries found this alignment")
    if shift > conf.max_burn_shift_mm:
        warnings.append(
            f"the alignment moves the burn's centre by {shift:.0f} mm on the skin (limit {conf.max_burn_shift_mm:g} mm)"
        )
    warning = ""
    if warnings:
        warning = "; ".join(warnings) + ": check that both visits show the same burn, and compare them by eye"
    log.info(
        "registered: RMSE %.3f mm, overlap %.2f, texture %s, %d/%d tries agree, burn shift %.1f mm",
        rmse,
        result.fitness,
        "-" if texture is None else f"{texture:.2f}",
        agreeing,
        len(tries),
        shift,
    )
    return Registration(
        method=("fpfh+texture" if texture is not None and conf.texture_feature_weight > 0 else "fpfh")
        + "_ransac+icp_"
        + ("point_to_plane" if conf.point_to_plane else "point_to_point"),
        transform_to_baseline=[[round(float(x), 9) for x in row] for row in transform],
        rmse_mm=round(rmse, 4),
        overlap=round(float(result.fitness), 4),
        texture_agreement=None if texture is None else round(texture, 3),
        points=len(skin),
        baseline_points=len(fine_base.points),
        ransac_tries=len(tries),
        ransac_agreeing=int(agreeing),
        burn_shift_mm=round(shift, 2),
        seconds=round(time.perf_counter() - started, 2),
        warning=warning,
    )
