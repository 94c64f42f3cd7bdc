"""Carrying one view's burn probability map onto the mesh vertices it sees.

A vertex takes the probability at its projection (bilinear) from a view only when the view really sees it:
it lands inside the picture, lies in front of the camera, faces it, and no other part of the surface is in the
way. Each such sample gets a weight, the cosine between the vertex normal and the ray to the camera, so
grazing looks, where a pixel smears over much skin and mislabelling is likeliest, count less.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import open3d as o3d

from processing.analysis.burn_region import check_mesh
from processing.reconstruction.views import View
from schemas.errors import InvalidInput

MARGIN_PX = 1.0
"""Vertices projecting closer than this to the picture border are not sampled (bilinear needs both neighbours)."""
MIN_FACING_COS = math.cos(math.radians(80.0))
"""A vertex faces a camera when normal · (direction to camera) exceeds this: views beyond 80° off normal are dropped."""
OCCLUSION_ABS_MM = 0.2
OCCLUSION_REL = 0.003
"""A vertex is hidden when the ray to it hits the surface more than 0.2 mm + 0.3 % of the distance before it
(~1 mm at 25-30 cm). That exceeds float32 ray-casting rounding and the sub-millimetre noise of a reconstructed
mesh, which would otherwise hide vertices behind their own bumps, yet stays well below the gap to any real
occluder (another body part, a skin fold)."""


@dataclass(frozen=True)
class ViewSample:
    """One view's reading of every vertex: probability p (0 where unseen), weight >= 0 (0 where unseen), seen."""

    p: np.ndarray
    weight: np.ndarray
    seen: np.ndarray


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Unit area-weighted vertex normals (zero for vertices without faces); faces wound counter-clockwise seen
    from outside give outward normals."""
    vertices, faces = check_mesh(vertices, faces)
    face_n = np.cross(vertices[faces[:, 1]] - vertices[faces[:, 0]], vertices[faces[:, 2]] - vertices[faces[:, 0]])
    normals = np.zeros_like(vertices)
    for k in range(3):
        np.add.at(normals, faces[:, k], face_n)
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    return np.divide(normals, length, out=np.zeros_like(normals), where=length > 0)


def build_scene(vertices: np.ndarray, faces: np.ndarray) -> o3d.t.geometry.RaycastingScene:
    """A ray-casting scene of the mesh, built once and shared by every view's visibility test."""
    vertices, faces = check_mesh(vertices, faces)
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(vertices.astype(np.float32)), o3d.core.Tensor(faces.astype(np.uint32)))
    return scene


def sample_view(
    vertices: np.ndarray,
    faces: np.ndarray,
    normals: np.ndarray,
    view: View,
    prob: np.ndarray,
    scene: o3d.t.geometry.RaycastingScene | None = None,
) -> ViewSample:
    """Probability, weight and visibility of every vertex in one view.

    prob is the view's burn probability map (height, width) in [0, 1], in the undistorted picture (same K);
    NaN marks pixels nobody looked at (outside the model's crop, outside the sensor after undistortion): a
    vertex landing there is not seen by this view, rather than seen as healthy.
    Pass `scene` from build_scene when sampling several views of one mesh.
    """
    vertices, faces = check_mesh(vertices, faces)
    normals = np.asarray(normals, dtype=np.float64)
    if normals.shape != vertices.shape:
        raise InvalidInput(f"normals must have the shape of vertices {vertices.shape}, got {normals.shape}")
    prob = _check_prob(prob, view)
    uv, z = view.project(vertices)
    to_camera = view.centre - vertices
    distance = np.linalg.norm(to_camera, axis=1)
    cos = np.einsum("ij,ij->i", normals, to_camera) / np.maximum(distance, 1e-12)
    u, v = uv[:, 0], uv[:, 1]
    inside = (
        (u >= MARGIN_PX) & (u <= view.width - 1 - MARGIN_PX) & (v >= MARGIN_PX) & (v <= view.height - 1 - MARGIN_PX)
    )
    seen = (z > 0) & inside & (cos > MIN_FACING_COS)
    candidates = np.flatnonzero(seen)
    seen[candidates] = _unoccluded(
        build_scene(vertices, faces) if scene is None else scene, view.centre, vertices[candidates]
    )
    p = np.zeros(len(vertices))
    p[seen] = bilinear(prob, uv[seen])
    looked_at = np.isfinite(p)
    seen &= looked_at
    p[~looked_at] = 0.0
    return ViewSample(p=p, weight=np.where(seen, cos, 0.0), seen=seen)


def sample_views(
    vertices: np.ndarray, faces: np.ndarray, views: list[View], probs: list[np.ndarray]
) -> tuple[np.ndarray, np.ndarray]:
    """Probabilities and weights (n_views, V) of all views, ready for fusion.fuse."""
    if len(views) != len(probs) or not views:
        raise InvalidInput(
            f"need one probability map per view and at least one view; got {len(views)} views and {len(probs)} maps"
        )
    vertices, faces = check_mesh(vertices, faces)
    normals = vertex_normals(vertices, faces)
    scene = build_scene(vertices, faces)
    samples = [
        sample_view(vertices, faces, normals, view, prob, scene) for view, prob in zip(views, probs, strict=True)
    ]
    w = np.stack([s.weight for s in samples])
    if not np.any(w > 0):
        raise InvalidInput(
            f"no mesh vertex is seen by any of the {len(views)} views; check that the cameras and the "
            "mesh share one coordinate frame and unit (mm) and that the faces are wound outwards"
        )
    return np.stack([s.p for s in samples]), w


def bilinear(image: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Image values at sub-pixel positions (N, 2), pixel centres at integers; positions must lie inside."""
    u0 = np.clip(np.floor(uv[:, 0]).astype(np.int64), 0, image.shape[1] - 2)
    v0 = np.clip(np.floor(uv[:, 1]).astype(np.int64), 0, image.shape[0] - 2)
    fu, fv = uv[:, 0] - u0, uv[:, 1] - v0
    top = (1 - fu) * image[v0, u0] + fu * image[v0, u0 + 1]
    bottom = (1 - fu) * image[v0 + 1, u0] + fu * image[v0 + 1, u0 + 1]
    return (1 - fv) * top + fv * bottom


def _unoccluded(scene: o3d.t.geometry.RaycastingScene, centre: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Whether the first surface hit on the ray from the camera centre to each point is the point itself."""
    if len(points) == 0:
        return np.zeros(0, dtype=bool)
    offset = points - centre
    distance = np.linalg.norm(offset, axis=1)
    rays = np.hstack([np.broadcast_to(centre, points.shape), offset / distance[:, None]]).astype(np.float32)
    hit = scene.cast_rays(o3d.core.Tensor(rays))["t_hit"].numpy()
    return hit >= distance - (OCCLUSION_ABS_MM + OCCLUSION_REL * distance)


def _check_prob(prob: np.ndarray, view: View) -> np.ndarray:
    prob = np.asarray(prob, dtype=np.float64)
    if prob.shape != (view.height, view.width):
        raise InvalidInput(
            f"probability map for view {view.name} has shape {prob.shape}, expected "
            f"({view.height}, {view.width}) (height, width) like the picture"
        )
    known = prob[np.isfinite(prob)]
    if np.isinf(prob).any() or (known.size and (known.min() < 0 or known.max() > 1)):
        raise InvalidInput(f"probability map for view {view.name} must hold values in [0, 1] (NaN: not looked at)")
    return prob
