"""Stage 3a: dense points by multi-view stereo over the SfM poses, inside the region of interest."""

from __future__ import annotations

import logging
import math
from pathlib import Path

import cv2
import msgspec
import numpy as np
import open3d as o3d

from processing.reconstruction import fusion, stereo
from processing.reconstruction.roi import Region, aim_point, region_of_interest
from processing.reconstruction.views import View, load_views, read_colour, read_gray, read_model
from processing.stages import read_json, write_json
from schemas.config import ReconstructionConfig
from schemas.errors import CaptureInsufficient
from schemas.reconstruction import FailureCode, ScaleResult

log = logging.getLogger(__name__)

POINTS = "fused_points.ply"
INFO = "dense_info.json"
MIN_POINTS = 2000
TYPICAL_DISTANCE_MM = 300.0


class DenseInfo(msgspec.Struct, frozen=True, kw_only=True):
    """What the dense stage hands to meshing."""

    roi_centres: list[list[float]]
    roi_radii: list[float]
    views_with_depth: int
    fused_points: int
    units: str
    units_per_mm: float
    """1 when scaled; otherwise model units per (assumed) mm, so mm-sized settings keep their proportions."""


def run(conf: ReconstructionConfig, model_dir: Path, images_dir: Path, scale_path: Path, out_dir: Path) -> Path:
    """Write out_dir/fused_points.ply (output frame, with normals and colours) and dense_info.json."""
    scale = read_json(scale_path, ScaleResult)
    views = [to_output_frame(v, np.array(scale.model_to_output)) for v in load_views(read_model(model_dir))]
    region, units_per_mm = _region(conf, views, scale)
    pictures = {v.name: stereo.Picture.build(v, read_gray(images_dir / v.name)) for v in views}
    maps = []
    for view in views:
        sources = choose_sources(view, views, region, conf.stereo_sources)
        if not sources:
            continue
        dm = stereo.depth_map(
            pictures[view.name],
            [pictures[s.name] for s in sources],
            region,
            conf.stereo_planes,
            conf.stereo_min_ncc,
            finest=1 if conf.stereo_full_resolution else 2,
        )
        if dm is not None and dm.valid.any():
            if not conf.stereo_full_resolution:
                dm = _to_full_resolution(dm)
            maps.append(dm)
    del pictures
    colours = {v.name: v.undistort_image(read_colour(images_dir / v.name)) for v in views}
    points, normals, rgb = fusion.fuse(maps, colours, conf.fusion_min_views)
    inside = region.contains(points)
    points, normals, rgb = points[inside], normals[inside], rgb[inside]
    if len(points) < MIN_POINTS:
        raise CaptureInsufficient(
            "no consistent surface could be found around the burn (too little texture, glare or motion); "
            "retake in even light, holding still for each picture",
            code=FailureCode.no_surface,
        )
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    cloud.normals = o3d.utility.Vector3dVector(normals)
    cloud.colors = o3d.utility.Vector3dVector(rgb)
    tmp = out_dir / (POINTS + ".tmp.ply")
    o3d.io.write_point_cloud(str(tmp), cloud)
    tmp.replace(out_dir / POINTS)
    units = "mm" if scale.estimate.mm_per_unit else "model units"
    info = DenseInfo(
        roi_centres=region.centres.tolist(),
        roi_radii=region.radii.tolist(),
        views_with_depth=len(maps),
        fused_points=len(points),
        units=units,
        units_per_mm=units_per_mm,
    )
    write_json(out_dir / INFO, info)
    log.info("dense: %d depth maps, %d fused points", len(maps), len(points))
    return out_dir / POINTS


def to_output_frame(view: View, similarity: np.ndarray) -> View:
    """The same camera seen from the output frame (x_out = s R_a x + t_a): depths scale by s."""
    s = float(np.cbrt(np.linalg.det(similarity[:3, :3])))
    rotation_a = similarity[:3, :3] / s
    R = view.R @ rotation_a.T
    t = s * view.t - R @ similarity[:3, 3]
    return View(view.name, view.image_id, view.width, view.height, view.K, view.dist, R, t)


def _region(conf: ReconstructionConfig, views: list[View], scale: ScaleResult) -> tuple[Region, float]:
    """The region of interest, and model units per mm (1 when scaled; guessed from a typical
    phone-to-skin distance otherwise, only to size the region and the mesh cells)."""
    similarity = np.array(scale.model_to_output)
    units_per_mm = 1.0
    if not scale.estimate.mm_per_unit:
        aim = aim_point(views)
        distance = np.median([np.linalg.norm(v.centre - aim) for v in views])
        units_per_mm = float(distance) / TYPICAL_DISTANCE_MM
    radius = conf.roi_radius_mm * units_per_mm
    marker = None
    if scale.marker_corners_model and scale.estimate.mm_per_unit:
        model_points = np.vstack([np.array(q) for q in scale.marker_corners_model.values()])
        marker = model_points @ similarity[:3, :3].T + similarity[:3, 3]
    return region_of_interest(views, radius, marker), units_per_mm


def choose_sources(ref: View, views: list[View], region: Region, count: int) -> list[View]:
    """Neighbours seeing the region from 5-45 degrees away, nearest to 20 degrees first."""
    target = region.centres[0]
    to_ref = ref.centre - target
    scored = []
    for view in views:
        if view.name == ref.name or region.pixel_box(view) is None:
            continue
        to_view = view.centre - target
        cosine = np.dot(to_ref, to_view) / (np.linalg.norm(to_ref) * np.linalg.norm(to_view))
        angle = math.degrees(math.acos(float(np.clip(cosine, -1, 1))))
        if 5.0 <= angle <= 45.0:
            scored.append((abs(angle - 20.0), view))
    return [v for _, v in sorted(scored, key=lambda item: item[0])[:count]]


def _to_full_resolution(dm: stereo.DepthMap) -> stereo.DepthMap:
    h, w = dm.depth.shape
    size = (w * 2, h * 2)
    depth = cv2.resize(dm.depth, size, interpolation=cv2.INTER_LINEAR)
    score = cv2.resize(dm.score, size, interpolation=cv2.INTER_NEAREST)
    valid = cv2.resize(dm.valid.astype(np.uint8), size, interpolation=cv2.INTER_NEAREST).astype(bool)
    return stereo.DepthMap(dm.view, dm.x0, dm.y0, depth, score, valid)
