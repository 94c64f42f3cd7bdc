"""Stage: carry each picture's burn probability onto the mesh and fuse the views per vertex.

    run(conf, views, mesh_ply, seg_dir, out_dir, aim, radius) -> out_dir/burn_surface.npz

The npz holds the mesh (output frame), the fused probability `q` under the configured rule and
under every other rule (for the comparison in benchmarks/analysis_accuracy.py), the number of
pictures seeing each vertex, and the views' names. burn_surface.glb is the mesh with the burn
painted (magenta, shaded by probability) over its own colours, for any glTF viewer.
"""

from __future__ import annotations

import logging
from pathlib import Path

import cv2
import msgspec
import numpy as np
import open3d as o3d
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from processing.analysis import fusion, paint, segment_views
from processing.analysis.burn_region import burn_area_mm2, mesh_edges, triangle_areas
from processing.analysis.projection import sample_views
from processing.reconstruction.dense import to_output_frame
from processing.reconstruction.mesh import write_glb
from processing.reconstruction.views import View, load_views, read_model
from processing.segmentation.infer import Box
from processing.stages import read_json
from schemas.analysis import SegmentationRecord, ViewMask
from schemas.config import AnalysisConfig
from schemas.errors import CaptureInsufficient, InvalidInput
from schemas.reconstruction import FailureCode, ScaleResult

log = logging.getLogger(__name__)

ARRAYS = "burn_surface.npz"
GLB = "burn_surface.glb"
PAINT = paint.PAINT


def output_views(model_dir: Path, scale_path: Path) -> list[View]:
    """The placed cameras in the mesh's frame (mm when scaled)."""
    similarity = np.array(read_json(scale_path, ScaleResult).model_to_output)
    return [to_output_frame(v, similarity) for v in load_views(read_model(model_dir))]


def crop_boxes(views: list[View], centre: np.ndarray, radius: float) -> dict[str, Box]:
    """Per picture, the square the model should look at (pixels as stored): around the burn centre, `radius` in
    mesh units."""
    boxes = {}
    for view in views:
        uv, z = view.project(centre[None])
        if z[0] <= 0:
            continue
        cx, cy = view.distort_points(uv)[0]
        r_px = float(view.K[0, 0]) * radius / float(z[0])
        boxes[view.name] = Box.around(float(cx), float(cy), r_px, view.width, view.height)
    return boxes


def read_probability(seg_dir: Path, record: ViewMask, view: View) -> np.ndarray:
    """The view's probability in the undistorted picture: a person's mask counts as 0/1; NaN where nobody
    looked (outside both of the model's squares, or outside the sensor)."""
    path = seg_dir / (record.probability or record.mask)
    image = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    if image is None:
        raise InvalidInput(f"{path} is missing or unreadable; run the analysis again with --fresh")
    prob = image.astype(np.float32) / 255.0
    if record.crop is not None:
        looked = np.full_like(prob, np.nan)
        for x0, y0, side in filter(None, (record.crop, record.fine_square)):
            looked[y0 : y0 + side, x0 : x0 + side] = prob[y0 : y0 + side, x0 : x0 + side]
        prob = looked
    return view.undistort_image(prob, outside=np.nan)


MIN_BURN_SHARE = 0.001
"""A burn on the surface smaller than this share of the skin the views looked at around it (0.06 cm2 of the
region a 45 mm crop sees) is no burn found: a few vertices over the threshold measure 0.0 cm2, never a result."""
STRAY_SHARE = 0.2
"""A separate burn region under this share of the largest one's area is set aside (neither burn nor healthy):
the model's specks on the drape or a shadow must not add area, edge length, or a false 'healthy' ring. A
satellite burn of a fifth of the main one or more still counts."""


def stray_regions(vertices: np.ndarray, faces: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Vertices of burn regions (q >= 0.5, connected through mesh edges) much smaller than the largest."""
    burn = np.nan_to_num(q) >= 0.5
    if not burn.any():
        return np.zeros(len(q), bool)
    edges = mesh_edges(faces)
    edges = edges[burn[edges[:, 0]] & burn[edges[:, 1]]]
    graph = coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(len(q), len(q)))
    _, label = connected_components(graph, directed=False)
    corner_area = np.repeat(triangle_areas(vertices[faces]) / 3, 3)
    area = np.bincount(label[faces.ravel()], weights=corner_area * burn[faces.ravel()], minlength=label.max() + 1)
    area[np.unique(label[~burn])] = 0.0  # a healthy vertex is a region of its own: not burn
    return burn & (area[label] < STRAY_SHARE * area.max())


def burn_found(vertices: np.ndarray, faces: np.ndarray, q: np.ndarray) -> bool:
    """Whether the fused burn (q >= 0.5; NaN: not looked at) covers at least MIN_BURN_SHARE of the skin looked at."""
    seen = ~np.isnan(q)
    looked_at = float(triangle_areas(vertices[faces[np.all(seen[faces], axis=1)]]).sum())
    return bool(np.any(np.nan_to_num(q) >= 0.5)) and burn_area_mm2(vertices, faces, q) > MIN_BURN_SHARE * looked_at


def run(
    conf: AnalysisConfig,
    views: list[View],
    mesh_ply: Path,
    seg_dir: Path,
    out_dir: Path,
    aim: np.ndarray,
    radius: float,
) -> Path:
    """`views` are the placed cameras in the mesh's frame (output_views). `aim` and `radius` bound where the burn can be: the region around the point the cameras aim at. The
    mesh also covers the marker's surroundings (for the scale), where a false detection on the drape or the
    marker must not count as burn."""
    mesh = o3d.io.read_triangle_mesh(str(mesh_ply))
    vertices, faces = np.asarray(mesh.vertices, np.float64), np.asarray(mesh.triangles, np.int64)
    record = msgspec.json.decode((seg_dir / segment_views.RECORD).read_bytes(), type=SegmentationRecord)
    records = {r.image: r for r in record.views}
    views = [v for v in views if v.name in records]
    probs = [read_probability(seg_dir, records[v.name], v) for v in views]
    p, w = sample_views(vertices, faces, views, probs)
    fused = {rule.value: fusion.fuse(rule, p, w) for rule in fusion.FusionRule}
    outside = np.linalg.norm(vertices - aim, axis=1) > radius
    for q_rule in fused.values():
        q_rule[outside] = np.nan  # not part of the burn region: neither burn nor healthy ring
        q_rule[stray_regions(vertices, faces, q_rule)] = np.nan
    q = fused[conf.fusion_rule]
    agreement = fusion.view_agreement(p, w, ~np.isnan(q))
    if not burn_found(vertices, faces, q):
        raise CaptureInsufficient(
            "no burn was found on the reconstructed surface (nothing, or only specks under "
            f"{MIN_BURN_SHARE:.1%} of the skin looked at); check the overlays, or draw the burn's outline on "
            "some photos (--masks) and run again",
            code=FailureCode.no_burn,
        )
    tmp = out_dir / (ARRAYS + ".tmp.npz")
    in_burn = np.nan_to_num(q) >= 0.5
    np.savez_compressed(
        tmp,
        vertices=vertices,
        faces=faces,
        q=q,
        views_per_vertex=fusion.views_per_vertex(w),
        view_sees_burn=np.any(w[:, in_burn] > 0, axis=1),
        view_names=np.array([v.name for v in views]),
        view_agreement=np.float64(np.nan if agreement is None else agreement),
        **{f"q_{k}": v for k, v in fused.items()},
    )
    tmp.replace(out_dir / ARRAYS)
    _write_painted(vertices, faces, np.asarray(mesh.vertex_colors), q, out_dir / GLB)
    log.info(
        "surface: %d vertices, %d seen by a picture, %d in the burn",
        len(vertices),
        int(np.sum(~np.isnan(q))),
        int(np.sum(np.nan_to_num(q) >= 0.5)),
    )
    return out_dir / ARRAYS


def _write_painted(vertices, faces, colours, q, path: Path) -> None:
    base = np.clip(colours, 0, 1) if len(colours) else np.full((len(vertices), 3), 0.7)
    alpha = paint.alpha(q)[:, None]
    write_glb(vertices, faces, base * (1 - alpha) + PAINT * alpha, path)
