"""Ray-cast rendering of one view on the CPU (Open3D's Embree scene), in linear light.

Rays go through sub-pixel centres of a supersampled image; each hit's texture coordinates and
normal are interpolated from its triangle's corners with the hit's barycentrics (Open3D gives
(u, v) with point = (1 - u - v) v0 + u v1 + v v2). Shading is Lambert from a key light (shadow
rays toward a slightly jittered direction: soft shadow edges) with its Blinn-Phong highlight, a
fill light and a hemispheric ambient. The supersampled image and masks are averaged down
(cv2.INTER_AREA); a mask pixel is set where more than half of it is burn (s <= 1 on the body) or body.

Per-hit vectors are kept channels-first, (3, K): numpy is several times faster on long rows
than on (K, 3) arrays, and the render is otherwise bound by exactly that arithmetic.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
import open3d as o3d

from processing.phantom.cameras import Camera
from processing.phantom.drape import NEAR_HALF_MM
from processing.phantom.scene import BODY, DRAPE, MARKER, Layer, Scene
from processing.phantom.textures import sample_image

KEY_COLOUR = np.array([1.0, 0.96, 0.9], np.float32)
FILL_COLOUR = np.array([0.85, 0.92, 1.0], np.float32)
AMBIENT_COLOUR = np.array([0.95, 0.97, 1.0], np.float32)
BACKGROUND = np.array([0.05, 0.05, 0.055], np.float32)
SKIN_WRAP = 0.25
"""Wrapped diffuse on skin: light reaches a little past the terminator, as through translucent skin."""
SHADOW_OFFSET_MM = 0.05
TILE_RAYS = 400_000
"""Rays per tile: temporaries stay small enough to be reused instead of freshly mapped (page faults)."""


@dataclass(frozen=True)
class RenderedView:
    linear: np.ndarray
    """(H, W, 3) float32 linear radiance (before exposure and noise)."""
    burn_mask: np.ndarray
    """(H, W) bool: visible burn."""
    object_mask: np.ndarray
    """(H, W) bool: visible skin of the body part."""


def _grid(camera: Camera, supersample: float) -> tuple[np.ndarray, np.ndarray]:
    """Normalised camera coordinates of the supersampled pixel centres' columns (x) and rows (y)."""
    hs, ws = int(round(camera.height * supersample)), int(round(camera.width * supersample))
    k = camera.K
    x = ((np.arange(ws) + 0.5) * camera.width / ws - 0.5 - k[0, 2]) / k[0, 0]
    y = ((np.arange(hs) + 0.5) * camera.height / hs - 0.5 - k[1, 2]) / k[1, 1]
    return x.astype(np.float32), y.astype(np.float32)


def _rays(camera: Camera, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """(3, N) unit world directions through the grid x (columns) by y (rows), row-major."""
    x, y = x[None, :], y[:, None]
    inverse_length = 1.0 / np.sqrt(x * x + y * y + 1.0)
    r = camera.R.astype(np.float32)
    directions = np.empty((3, y.shape[0], x.shape[1]), np.float32)
    for axis in range(3):  # world direction = R^T (x, y, 1)
        directions[axis] = (x * r[0, axis] + y * r[1, axis] + r[2, axis]) * inverse_length
    return directions.reshape(3, -1)


def _dot(a: np.ndarray, b) -> np.ndarray:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _normalise(v: np.ndarray) -> np.ndarray:
    """(3, K) rows to unit length, in place."""
    v /= np.maximum(np.sqrt(_dot(v, v)), 1e-12)
    return v


def _interpolate(layer: Layer, prim: np.ndarray, bary: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(2, K) texture coordinates and (3, K) unit normals at hits on `layer`."""
    w1, w2 = bary[:, 0], bary[:, 1]
    w0 = 1.0 - w1 - w2
    uv = layer.face_uv[prim]
    uv = np.stack([w0 * uv[:, 0, c] + w1 * uv[:, 1, c] + w2 * uv[:, 2, c] for c in range(2)])
    n = layer.face_normals[prim]
    n = np.stack([w0 * n[:, 0, c] + w1 * n[:, 1, c] + w2 * n[:, 2, c] for c in range(3)])
    return uv, _normalise(n)


def _drape_attributes(scene: Scene, position: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The drape's texture coordinates are world (x, y) and its grid's normals a look-up: no per-hit gathers."""
    index = np.arange(len(scene.drape_axis), dtype=np.float64)
    col = np.interp(position[0], scene.drape_axis, index).astype(np.float32)
    row = np.interp(position[1], scene.drape_axis, index).astype(np.float32)
    return position[:2], _normalise(np.ascontiguousarray(sample_image(scene.drape_normal_map, col, row).T))


def _albedo(scene: Scene, geometry: int, uv: np.ndarray) -> np.ndarray:
    """(4, K): linear RGB albedo and specular strength."""
    if geometry == BODY:
        return np.ascontiguousarray(scene.body_texture.sample(uv[0], uv[1]).T)
    if geometry == MARKER:
        return np.ascontiguousarray(scene.marker_texture.sample(uv[0], uv[1]).T)
    near = (np.abs(uv[0]) < NEAR_HALF_MM - 2.0) & (np.abs(uv[1]) < NEAR_HALF_MM - 2.0)
    out = np.zeros((4, uv.shape[1]), np.float32)  # cloth is matte: no specular strength
    for texture, where in ((scene.cloth.near, near), (scene.cloth.far, ~near)):
        pick = np.flatnonzero(where)
        if len(pick):
            out[:3, pick] = texture.sample(uv[0, pick], uv[1, pick]).T
    return out


def _light_disc(direction: np.ndarray, spread_deg: float, rng: np.random.Generator) -> np.ndarray:
    """256 directions spread over the key light's disc, (256, 3); shadow rays pick among them at random,
    and the shadow edge averages them within every pixel."""
    e1 = np.cross(direction, [0.0, 0.0, 1.0] if abs(direction[2]) < 0.9 else [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(direction, e1)
    spread = math.tan(math.radians(spread_deg))
    r, a = np.sqrt(rng.random(256)) * spread, rng.random(256) * 2 * math.pi
    table = direction + (r * np.cos(a))[:, None] * e1 + (r * np.sin(a))[:, None] * e2
    return (table / np.linalg.norm(table, axis=1, keepdims=True)).astype(np.float32)


def _key_visibility(
    scene: Scene,
    position: np.ndarray,
    n: np.ndarray,
    lit: np.ndarray,
    gid: int,
    disc: np.ndarray,
    rng: np.random.Generator,
) -> np.ndarray:
    if gid == DRAPE:  # the drape's folds are too gentle to shade themselves: only the body part's shadow falls on it
        x0, x1, y0, y1 = scene.shadow_box
        lit = lit & (position[0] > x0) & (position[0] < x1) & (position[1] > y0) & (position[1] < y1)
    visible = np.ones(position.shape[1], np.float32)
    cast = np.flatnonzero(lit)
    if len(cast):
        rays = np.empty((len(cast), 6), np.float32)
        rays[:, :3] = (position[:, cast] + np.float32(SHADOW_OFFSET_MM) * n[:, cast]).T
        rays[:, 3:] = disc[rng.integers(0, len(disc), len(cast), dtype=np.uint8)]
        visible[cast] = ~scene.raycaster.test_occlusions(o3d.core.Tensor(rays)).numpy()
    return visible


def _shade(
    scene: Scene,
    layer: Layer,
    gid: int,
    wrap: float,
    origin: np.ndarray,
    directions: np.ndarray,
    t_hit: np.ndarray,
    prim: np.ndarray,
    bary: np.ndarray,
    disc: np.ndarray,
    rng: np.random.Generator,
) -> tuple[np.ndarray, np.ndarray]:
    """(3, K) linear radiance and (2, K) texture coordinates of the hits on one layer."""
    lights = scene.lights
    key_dir, fill_dir = lights.key_dir.astype(np.float32), lights.fill_dir.astype(np.float32)
    position = origin[:, None] + t_hit * directions
    uv, n = _drape_attributes(scene, position) if gid == DRAPE else _interpolate(layer, prim, bary)
    if gid == BODY:  # the drape and the strip face up, toward every camera
        n *= np.where(_dot(n, directions) > 0, np.float32(-1.0), np.float32(1.0))
    texel = _albedo(scene, gid, uv)
    n_key = _dot(n, key_dir)
    visible = _key_visibility(scene, position, n, n_key > -wrap, gid, disc, rng)
    ambient = lights.ambient * (0.7 + 0.3 * n[2])
    key = lights.key * np.maximum((n_key + wrap) / (1.0 + wrap), 0.0) * visible
    fill = lights.fill * np.maximum((_dot(n, fill_dir) + wrap) / (1.0 + wrap), 0.0)
    radiance = np.stack(
        [texel[c] * (AMBIENT_COLOUR[c] * ambient + KEY_COLOUR[c] * key + FILL_COLOUR[c] * fill) for c in range(3)]
    )
    glossy = np.flatnonzero((texel[3] > 0) & (n_key > 0) & (visible > 0))
    if len(glossy):
        half = _normalise(key_dir[:, None] - directions[:, glossy])
        norm = (lights.shininess + 8.0) / (8.0 * math.pi)
        gloss = np.maximum(_dot(n[:, glossy], half), 0.0) ** np.float32(lights.shininess)
        gloss *= np.float32(norm * lights.key) * texel[3, glossy]
        radiance[:, glossy] += KEY_COLOUR[:, None] * gloss
    return radiance, uv


def render_view(scene: Scene, camera: Camera, supersample: float, rng: np.random.Generator) -> RenderedView:
    x, y = _grid(camera, supersample)
    hs, ws = len(y), len(x)
    origin = camera.centre.astype(np.float32)
    disc = _light_disc(scene.lights.key_dir, scene.lights.key_spread_deg, rng)
    image = np.empty((3, hs * ws), np.float32)
    burn = np.zeros(hs * ws, np.float32)
    body = np.zeros(hs * ws, np.float32)
    rows = max(1, TILE_RAYS // ws)
    for r0 in range(0, hs, rows):
        directions = _rays(camera, x, y[r0 : r0 + rows])
        count, offset = directions.shape[1], r0 * ws
        rays = np.empty((count, 6), np.float32)
        rays[:, :3], rays[:, 3:] = origin, directions.T
        hit = scene.raycaster.cast_rays(o3d.core.Tensor(rays))
        t_hit, geometry = hit["t_hit"].numpy(), hit["geometry_ids"].numpy()
        prim, bary = hit["primitive_ids"].numpy(), hit["primitive_uvs"].numpy()
        image[:, offset : offset + count] = BACKGROUND[:, None]
        for gid, layer, wrap in ((BODY, scene.body, SKIN_WRAP), (DRAPE, scene.drape, 0.0), (MARKER, scene.marker, 0.0)):
            idx = np.flatnonzero(geometry == gid)
            if len(idx) == 0:
                continue
            radiance, uv = _shade(
                scene, layer, gid, wrap, origin, directions[:, idx], t_hit[idx], prim[idx], bary[idx], disc, rng
            )
            image[:, offset + idx] = radiance
            if gid == BODY:
                body[offset + idx] = 1.0
                s, _ = scene.burn.polar(uv[0].astype(np.float64), uv[1].astype(np.float64))
                burn[offset + idx] = s <= 1.0

    size = (camera.width, camera.height)
    linear = cv2.resize(
        np.ascontiguousarray(image.reshape(3, hs, ws).transpose(1, 2, 0)), size, interpolation=cv2.INTER_AREA
    )
    burn_mask = cv2.resize(burn.reshape(hs, ws), size, interpolation=cv2.INTER_AREA) > 0.5
    object_mask = cv2.resize(body.reshape(hs, ws), size, interpolation=cv2.INTER_AREA) > 0.5
    return RenderedView(linear=linear, burn_mask=burn_mask, object_mask=object_mask)
