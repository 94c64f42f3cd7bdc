"""Stage 3b: a surface mesh from the fused points (screened Poisson, density-trimmed, cut to the region)."""

from __future__ import annotations

import logging
import math
from pathlib import Path

import numpy as np
import open3d as o3d
import trimesh

from processing.reconstruction.dense import INFO, DenseInfo
from processing.reconstruction.roi import Region
from processing.stages import read_json, write_json
from schemas.config import ReconstructionConfig
from schemas.errors import CaptureInsufficient
from schemas.reconstruction import DenseQuality, FailureCode

log = logging.getLogger(__name__)

PLY = "surface.ply"
GLB = "surface.glb"
QUALITY = "dense_quality.json"
VOXEL_FRACTION = 0.5
"""Points are thinned to one per half mesh cell before Poisson (averaging neighbours, cutting time)."""
MIN_COMPONENT_SHARE = 0.05


def run(conf: ReconstructionConfig, dense_dir: Path, out_dir: Path) -> Path:
    """Write surface.ply, surface.glb (output frame; mm when scaled) and dense_quality.json."""
    info = read_json(dense_dir / INFO, DenseInfo)
    cloud = o3d.io.read_point_cloud(str(dense_dir / "fused_points.ply"))
    cell = conf.mesh_cell_mm * info.units_per_mm
    cloud = cloud.voxel_down_sample(cell * VOXEL_FRACTION)
    region = Region(np.array(info.roi_centres), np.array(info.roi_radii))
    extent = float(np.max(cloud.get_max_bound() - cloud.get_min_bound()))
    depth = int(math.ceil(math.log2(max(extent, 1e-9) / cell)))
    mesh, densities = o3d.geometry.TriangleMesh.create_from_point_cloud_poisson(
        cloud, depth=min(max(depth, 6), 11), scale=1.1, linear_fit=False, n_threads=conf.mesh_threads
    )
    densities = np.asarray(densities)
    vertices = np.asarray(mesh.vertices)
    drop = (densities < np.quantile(densities, conf.mesh_density_quantile)) | ~region.contains(vertices)
    mesh.remove_vertices_by_mask(drop)
    mesh = _largest_parts(mesh)
    if len(mesh.triangles) == 0:
        raise CaptureInsufficient(
            "no surface could be built around the burn; retake in even light", code=FailureCode.no_surface
        )
    mesh.compute_vertex_normals()
    tmp = out_dir / (PLY + ".tmp.ply")
    o3d.io.write_triangle_mesh(str(tmp), mesh, write_ascii=False)
    tmp.replace(out_dir / PLY)
    write_glb(np.asarray(mesh.vertices), np.asarray(mesh.triangles), np.asarray(mesh.vertex_colors), out_dir / GLB)
    quality = DenseQuality(
        method="cpu-plane-sweep",
        units=info.units,
        roi_centre=[round(c, 3) for c in info.roi_centres[0]],
        roi_radius=round(info.roi_radii[0], 3),
        views_with_depth=info.views_with_depth,
        fused_points=info.fused_points,
        mesh_vertices=len(mesh.vertices),
        mesh_faces=len(mesh.triangles),
        mesh_area=round(float(mesh.get_surface_area()), 3),
    )
    write_json(out_dir / QUALITY, quality)
    log.info("mesh: %d vertices, %d faces", len(mesh.vertices), len(mesh.triangles))
    return out_dir / PLY


def _largest_parts(mesh: o3d.geometry.TriangleMesh) -> o3d.geometry.TriangleMesh:
    """Drop floating fragments: connected parts with under 5 % of the largest part's triangles."""
    if len(mesh.triangles) == 0:
        return mesh
    clusters, counts, _ = mesh.cluster_connected_triangles()
    clusters, counts = np.asarray(clusters), np.asarray(counts)
    mesh.remove_triangles_by_mask(counts[clusters] < MIN_COMPONENT_SHARE * counts.max())
    mesh.remove_unreferenced_vertices()
    return mesh


def write_glb(vertices: np.ndarray, faces: np.ndarray, colours: np.ndarray | None, path: Path) -> Path:
    """A glTF binary of the mesh with vertex colours (RGB in [0, 1], or None), written atomically."""
    tri = trimesh.Trimesh(
        vertices=vertices,
        faces=faces,
        process=False,
        vertex_colors=(np.clip(colours, 0, 1) * 255).astype(np.uint8) if colours is not None and len(colours) else None,
    )
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_bytes(trimesh.exchange.gltf.export_glb(trimesh.Scene(tri)))
    tmp.replace(path)
    return path
