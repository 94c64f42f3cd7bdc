"""One session's world: the body part (cratered, moved by its object-to-world transform), the drape,
the marker strip, the lights, and an Open3D ray-casting scene over them.

Geometry ids in the ray-casting scene are BODY, DRAPE and MARKER, in that order.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
import open3d as o3d

from processing.phantom.burn import Burn
from processing.phantom.drape import RASTER_MM, DrapeCloth, drape_mesh, grid_axis, raster_index
from processing.phantom.marker_strip import MarkerStrip, place_strip
from processing.phantom.meshing import vertex_normals
from processing.phantom.surfaces import Surface
from processing.phantom.textures import ChartTexture

BODY, DRAPE, MARKER = 0, 1, 2


@dataclass(frozen=True)
class Layer:
    vertices: np.ndarray
    """(N, 3) world mm."""
    faces: np.ndarray
    uv: np.ndarray
    """(N, 2) texture chart coordinates, mm: the body's (p, q), the drape's world (x, y), the strip's (a, b)."""
    normals: np.ndarray
    """(N, 3) unit vertex normals, world."""
    face_uv: np.ndarray
    """(M, 3, 2) float32 texture coordinates of each face's corners: one gather per hit when rendering."""
    face_normals: np.ndarray
    """(M, 3, 3) float32 vertex normals of each face's corners."""


def make_layer(vertices: np.ndarray, faces: np.ndarray, uv: np.ndarray, normals: np.ndarray) -> Layer:
    return Layer(
        vertices=vertices,
        faces=faces,
        uv=uv,
        normals=normals,
        face_uv=uv[faces].astype(np.float32),
        face_normals=normals[faces].astype(np.float32),
    )


@dataclass(frozen=True)
class Lights:
    key_dir: np.ndarray
    """Unit vector toward the key light (it casts shadows)."""
    key: float
    fill_dir: np.ndarray
    fill: float
    ambient: float
    shininess: float
    key_spread_deg: float
    """Half-angle of the key light's disc: soft shadow edges."""

    def describe(self) -> dict[str, Any]:
        return {
            "model": "linear-light Lambert (wrapped a little on skin) + Blinn-Phong specular, directional key "
            "and fill, hemispheric ambient; the key casts soft shadows (jittered shadow rays)",
            "key_dir_world": self.key_dir.tolist(),
            "key": self.key,
            "fill_dir_world": self.fill_dir.tolist(),
            "fill": self.fill,
            "ambient": self.ambient,
            "shininess": self.shininess,
            "key_spread_deg": self.key_spread_deg,
        }


def _direction(azimuth: float, elevation: float) -> np.ndarray:
    return np.array(
        [math.cos(elevation) * math.cos(azimuth), math.cos(elevation) * math.sin(azimuth), math.sin(elevation)]
    )


def sample_lights(rng: np.random.Generator) -> Lights:
    azimuth = rng.uniform(0, 2 * math.pi)
    return Lights(
        key_dir=_direction(azimuth, math.radians(rng.uniform(45, 70))),
        key=float(rng.uniform(0.85, 1.0)),
        fill_dir=_direction(azimuth + math.pi + rng.uniform(-0.6, 0.6), math.radians(rng.uniform(35, 60))),
        fill=float(rng.uniform(0.18, 0.3)),
        ambient=float(rng.uniform(0.22, 0.32)),
        shininess=40.0,
        key_spread_deg=2.0,
    )


@dataclass
class Scene:
    surface: Surface
    burn: Burn
    object_to_world: np.ndarray
    body: Layer
    drape: Layer
    marker: Layer
    body_texture: ChartTexture
    cloth: DrapeCloth
    marker_texture: ChartTexture
    strip: MarkerStrip
    lights: Lights
    raycaster: o3d.t.geometry.RaycastingScene
    drape_axis: np.ndarray
    """The drape grid's lines (x and y alike)."""
    drape_normal_map: np.ndarray
    """(A, A, 3) float32 vertex normals of the drape grid, row = y line, column = x line."""
    shadow_box: tuple[float, float, float, float]
    """x_min, x_max, y_min, y_max outside which nothing can shade the drape from the key light."""

    def burn_centre_world(self) -> tuple[np.ndarray, np.ndarray]:
        """Burn centre on the undisplaced surface and the outward normal there, world."""
        p, q = (np.array([c]) for c in self.burn.centre)
        centre = transform(self.object_to_world, self.surface.real_point(p, q))[0]
        return centre, self.object_to_world[:3, :3] @ self.surface.normal(p, q)[0]

    def boundary_world(self, count: int) -> np.ndarray:
        """`count` points along the burn boundary (s = 1), evenly spaced in theta, world."""
        theta = 2 * math.pi * np.arange(count) / count
        return transform(self.object_to_world, self.surface.real_point(*self.burn.chart_point(np.ones(count), theta)))

    def visible(self, origin: np.ndarray, points: np.ndarray) -> np.ndarray:
        """Whether each world point is seen unobstructed from `origin`."""
        direction = points - origin
        distance = np.linalg.norm(direction, axis=1)
        rays = np.concatenate([np.broadcast_to(origin, points.shape), direction / distance[:, None]], 1)
        hits = self.raycaster.cast_rays(o3d.core.Tensor(rays.astype(np.float32)))["t_hit"].numpy()
        return hits >= distance - 0.05


def transform(matrix: np.ndarray, points: np.ndarray) -> np.ndarray:
    return points @ matrix[:3, :3].T + matrix[:3, 3]


def body_layer(surface: Surface, burn: Burn, object_to_world: np.ndarray, spacing_mm: float) -> Layer:
    p, q, faces = surface.render_chart_mesh(spacing_mm)
    s, _ = burn.polar(p, q)
    vertices = surface.real_point(p, q)
    inside = s < 1.0
    if burn.depth_mm > 0:
        vertices[inside] -= burn.displacement(s[inside])[:, None] * surface.normal(p[inside], q[inside])
    world = transform(object_to_world, vertices)
    return make_layer(world, faces, np.stack([p, q], 1), vertex_normals(world, faces))


def _footprint(body: Layer) -> np.ndarray:
    n = int(1200 / RASTER_MM)
    raster = np.zeros((n, n), np.uint8)
    row, col = raster_index(body.vertices[:, :2])
    raster[row, col] = 1
    return cv2.dilate(raster, np.ones((3, 3), np.uint8)).astype(bool)


def build_scene(
    surface: Surface,
    burn: Burn,
    object_to_world: np.ndarray,
    body_texture: ChartTexture,
    cloth: DrapeCloth,
    marker_texture: ChartTexture,
    marker_ids: tuple[int, int, int],
    spacing_mm: float,
    rng: np.random.Generator,
) -> Scene:
    body = body_layer(surface, burn, object_to_world, spacing_mm)
    footprint = _footprint(body)
    centre = transform(object_to_world, surface.real_point(*[np.array([c]) for c in burn.centre]))[0]
    long_axis = object_to_world[:2, 0] / np.linalg.norm(object_to_world[:2, 0])
    strip = place_strip(marker_ids, footprint, centre[:2], long_axis, rng)
    quad, quad_faces, quad_uv = strip.quad()
    marker = make_layer(quad, quad_faces, quad_uv, np.tile([0.0, 0.0, 1.0], (4, 1)))

    flat = footprint.astype(np.uint8)
    row, col = raster_index(quad[:, :2])
    cv2.fillConvexPoly(flat, np.stack([col, row], 1).astype(np.int32), 1)
    drape_vertices, drape_faces = drape_mesh(cloth, flat.astype(bool))
    drape = make_layer(
        drape_vertices, drape_faces, drape_vertices[:, :2].copy(), vertex_normals(drape_vertices, drape_faces)
    )

    raycaster = o3d.t.geometry.RaycastingScene()
    for layer in (body, drape, marker):
        raycaster.add_triangles(
            o3d.core.Tensor(layer.vertices.astype(np.float32)), o3d.core.Tensor(layer.faces.astype(np.uint32))
        )
    lights = sample_lights(rng)
    # The drape's folds are too gentle to shade themselves, so only the body part casts shadows on it.
    reach = body.vertices[:, 2].max() / math.tan(math.asin(lights.key_dir[2])) + 15.0
    lo, hi = body.vertices[:, :2].min(axis=0) - reach, body.vertices[:, :2].max(axis=0) + reach
    grid = grid_axis()
    return Scene(
        surface=surface,
        burn=burn,
        object_to_world=object_to_world,
        body=body,
        drape=drape,
        marker=marker,
        body_texture=body_texture,
        cloth=cloth,
        marker_texture=marker_texture,
        strip=strip,
        lights=lights,
        raycaster=raycaster,
        drape_axis=grid,
        drape_normal_map=drape.normals.reshape(len(grid), len(grid), 3).astype(np.float32),
        shadow_box=(float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])),
    )
