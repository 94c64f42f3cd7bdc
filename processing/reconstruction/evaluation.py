"""Accuracy of an analysis against a phantom's ground truth (ours, or the independent generator's).

The reconstruction is scaled by the marker alone. Only to compare it with the truth is it placed
in the phantom's world, rigidly (never rescaled): the rotation comes from a similarity fit of the
SfM camera centres to the true ones, and the translation pins the burn centre to where that fit
puts it. Pinning at the burn (not at the cameras, ~300 mm away) keeps a scale error from being
counted ~6 times over as a depth offset; what remains is shape error plus the scale error over
the burn's own size.

- Scale error: distances between camera centres, ours (mm, marker scale) over the true ones, minus 1.
- Surface: when the phantom ships its true surface (true_surface.npz, our generator), the distance
  from every mesh vertex over the burn (s <= 1) to that surface; otherwise (the independent
  generator publishes no surface) the distance from the exactly known surface points -- the
  burn boundary and the crater bottom -- to the mesh.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import open3d as o3d
from scipy.spatial import cKDTree

from processing.reconstruction.dense import to_output_frame
from processing.reconstruction.pipeline import paths
from processing.reconstruction.views import load_views, read_model
from processing.stages import read_json
from schemas.reconstruction import ScaleResult


@dataclass
class Accuracy:
    phantom: str
    views: int
    registered: int
    scale_error: float
    """Signed relative error of the marker scale."""
    camera_rms_mm: float
    """Camera centres after the rigid placement: pose error plus the scale error over ~300 mm, in mm."""
    surface_median_mm: float
    surface_p95_mm: float
    surface_samples: int
    surface_method: str

    def as_dict(self) -> dict:
        return asdict(self)


def evaluate(analysis: Path, phantom: Path) -> Accuracy:
    truth = json.loads((phantom / "ground_truth.json").read_text())
    p = paths(analysis)
    placement = place(analysis, truth)
    mesh = o3d.io.read_triangle_mesh(str(p["mesh_ply"]))
    vertices = placement.apply(np.asarray(mesh.vertices))
    faces = np.asarray(mesh.triangles)
    if (phantom / "true_surface.npz").exists():
        distances, method = _mesh_to_truth(vertices, np.load(phantom / "true_surface.npz")), "mesh-to-true-surface"
    else:
        distances, method = _truth_points_to_mesh(vertices, faces, truth), "true-points-to-mesh"
    return Accuracy(
        phantom=phantom.name,
        views=len(truth["cameras"]),
        registered=placement.registered,
        scale_error=placement.scale_error,
        camera_rms_mm=placement.camera_rms_mm,
        surface_median_mm=float(np.median(distances)),
        surface_p95_mm=float(np.percentile(distances, 95)),
        surface_samples=len(distances),
        surface_method=method,
    )


def sparse_baseline(analysis: Path, phantom: Path) -> float | None:
    """Median distance to the true surface of the SfM points over the burn (None without a true surface)."""
    if not (phantom / "true_surface.npz").exists():
        return None
    truth = json.loads((phantom / "ground_truth.json").read_text())
    placement = place(analysis, truth)
    model = read_model(paths(analysis)["sfm_model"])
    points = np.array([p.xyz for p in model.points3D.values()])
    similarity = np.array(read_json(paths(analysis)["scale"], ScaleResult).model_to_output)
    points = placement.apply(points @ similarity[:3, :3].T + similarity[:3, 3])
    return float(np.median(_mesh_to_truth(points, np.load(phantom / "true_surface.npz"))))


@dataclass
class Placement:
    """The rigid move of an analysis's output frame into the phantom's world, and what it revealed."""

    rotation: np.ndarray
    translation: np.ndarray
    registered: int
    scale_error: float
    camera_rms_mm: float

    def apply(self, points: np.ndarray) -> np.ndarray:
        return points @ self.rotation.T + self.translation


def place(analysis: Path, truth: dict) -> Placement:
    p = paths(analysis)
    similarity = np.array(read_json(p["scale"], ScaleResult).model_to_output)
    ours = {v.name.rsplit(".", 1)[0]: to_output_frame(v, similarity) for v in load_views(read_model(p["sfm_model"]))}
    cams = [c for c in truth["cameras"] if c["name"] in ours]
    mine = np.array([ours[c["name"]].centre for c in cams])
    true = np.array([-np.array(c["R"]).T @ np.array(c["t"]) for c in cams])
    sigma, rotation, translation = similarity_fit(mine, true)
    burn = np.array(truth["burn_centre_world_mm"])
    pivot = rotation.T @ (burn - translation) / sigma
    translation = burn - rotation @ pivot
    placed = mine @ rotation.T + translation
    iu = np.triu_indices(len(cams), 1)
    d_mine = np.linalg.norm(mine[:, None] - mine[None], axis=2)[iu]
    d_true = np.linalg.norm(true[:, None] - true[None], axis=2)[iu]
    return Placement(
        rotation,
        translation,
        len(cams),
        scale_error=float(np.median(d_mine / d_true) - 1.0),
        camera_rms_mm=float(np.sqrt(np.mean(np.sum((placed - true) ** 2, axis=1)))),
    )


def similarity_fit(source: np.ndarray, target: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Scale, rotation and translation taking `source` points closest to `target` (Umeyama)."""
    cs, ct = source.mean(axis=0), target.mean(axis=0)
    a, b = source - cs, target - ct
    u, singular, vt = np.linalg.svd(a.T @ b)
    d = np.diag([1.0, 1.0, np.sign(np.linalg.det(vt.T @ u.T))])
    rotation = vt.T @ d @ u.T
    sigma = float(np.trace(np.diag(singular) @ d) / np.sum(a * a))
    return sigma, rotation, ct - sigma * rotation @ cs


def _scene(vertices: np.ndarray, faces: np.ndarray) -> o3d.t.geometry.RaycastingScene:
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(vertices.astype(np.float32)), o3d.core.Tensor(faces.astype(np.uint32)))
    return scene


def _mesh_to_truth(vertices: np.ndarray, surface) -> np.ndarray:
    true_v, true_f, burn_s = surface["vertices"], surface["faces"], surface["burn_s"]
    _, nearest = cKDTree(true_v).query(vertices, distance_upper_bound=5.0)
    over_burn = nearest < len(true_v)
    over_burn[over_burn] = burn_s[nearest[over_burn]] <= 1.0
    query = o3d.core.Tensor(vertices[over_burn].astype(np.float32))
    return _scene(true_v, true_f).compute_distance(query).numpy()


def _truth_points_to_mesh(vertices: np.ndarray, faces: np.ndarray, truth: dict) -> np.ndarray:
    boundary = np.array(truth["burn_boundary_world_mm"])
    bottom = np.array(truth["burn_centre_world_mm"]) - truth["max_depth_mm"] * np.array(truth["burn_normal_world"])
    query = o3d.core.Tensor(np.vstack([boundary, bottom[None]]).astype(np.float32))
    return _scene(vertices, faces).compute_distance(query).numpy()
