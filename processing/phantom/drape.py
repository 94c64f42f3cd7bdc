"""The textured cloth the body part and the marker lie on: a height field z = h(x, y) >= 0 in world mm.

Flat (z = 0) within FLAT_MM of the body part's footprint and the marker strip, rising over
RAMP_MM into soft folds further out. Its texture is patterned cloth in world (x, y): a fine
texture near the scene and a coarse one out to the edges; both come from the same noise
fields, and the near one's extra detail fades out before its edge, so there is no seam. Cloth is matte: its textures are RGB only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from processing.phantom.meshing import grid_faces
from processing.phantom.textures import (
    ChartTexture,
    draw_dots,
    draw_strands,
    random_strands,
    sample_image,
    sigmoid,
    smooth_noise,
    srgb_to_linear,
    texel_centres,
)

FLAT_MM = 15.0
RAMP_MM = 70.0
FOLD_MM = 14.0
NEAR_HALF_MM = 400.0
FAR_HALF_MM = 1500.0
FAR_TEXEL_MM = 3.0
RASTER_MM = 2.0
PALETTES_SRGB = [
    [(0.20, 0.33, 0.52), (0.75, 0.78, 0.80), (0.55, 0.28, 0.22), (0.93, 0.85, 0.55)],
    [(0.24, 0.42, 0.36), (0.82, 0.79, 0.70), (0.40, 0.30, 0.46), (0.92, 0.62, 0.32)],
    [(0.38, 0.40, 0.44), (0.86, 0.86, 0.82), (0.18, 0.38, 0.52), (0.85, 0.35, 0.30)],
]


@dataclass(frozen=True)
class DrapeCloth:
    """The cloth's look (the same cloth in every session of a series)."""

    near: ChartTexture
    """Linear RGB (no specular: cloth is matte) within NEAR_HALF_MM."""
    far: ChartTexture
    waves: list[tuple[float, float, float, float]]
    """(kx, ky, phase, weight) of the folds."""
    palette_srgb: list[tuple[float, float, float]]


def _colour(fields: np.ndarray, palette: np.ndarray, sharpness: np.ndarray | float) -> np.ndarray:
    f1, f2, f3 = fields[..., 0:1], fields[..., 1:2], fields[..., 2:3]
    c = np.broadcast_to(palette[0], (*fields.shape[:-1], 3)).copy()
    c += (palette[1] - c) * sigmoid(sharpness * (f1 - 0.2))
    c += (palette[2] - c) * sigmoid(sharpness * (f2 - 0.75))
    return c * (1.0 + 0.08 * f3)


def make_cloth(rng: np.random.Generator, near_texel_mm: float) -> DrapeCloth:
    palette_srgb = PALETTES_SRGB[int(rng.integers(len(PALETTES_SRGB)))]
    palette = srgb_to_linear(palette_srgb)
    far_n = int(2 * FAR_HALF_MM / FAR_TEXEL_MM)
    fields = np.stack([smooth_noise((far_n, far_n), sigma / FAR_TEXEL_MM, rng) for sigma in (22.0, 9.0, 60.0)], -1)
    far_origin = (-FAR_HALF_MM, -FAR_HALF_MM)
    far = _colour(fields, palette, 6.0)

    near_n = int(math.ceil(2 * NEAR_HALF_MM / near_texel_mm))
    x, y = texel_centres((near_n, near_n), (-NEAR_HALF_MM, -NEAR_HALF_MM), near_texel_mm)
    far_tex = ChartTexture(fields.astype(np.float32), far_origin, FAR_TEXEL_MM)
    near_fields = far_tex.sample(x.ravel(), y.ravel()).reshape(near_n, near_n, 3)
    fade = np.clip((NEAR_HALF_MM - 5.0 - np.maximum(np.abs(x), np.abs(y))) / 40.0, 0.0, 1.0)[..., None]
    del x, y
    # Crisp print edges, speckle, weave grain and stray fibres: the fine detail a sharp photo of cloth shows.
    near = _colour(near_fields, palette, 6.0 + 60.0 * fade)
    mm = 1.0 / near_texel_mm
    grain = smooth_noise((near_n, near_n), max(0.5 * mm, 0.5), rng)[..., None]
    near *= 1.0 + 0.15 * grain * fade
    area_cm2 = (2 * NEAR_HALF_MM) ** 2 / 100
    n_dots = int(2.0 * area_cm2)
    dots = draw_dots(
        (near_n, near_n),
        rng.uniform(0, near_n, (n_dots, 2)),
        rng.uniform(0.5, 2.0, n_dots) * mm,
        rng.uniform(0.7, 1.0, n_dots),
    )[..., None]
    near += (palette[3] - near) * dots * fade
    n_fibres = int(1.5 * area_cm2)
    fibres = random_strands(rng, n_fibres, (near_n, near_n), (2.0 * mm, 8.0 * mm), 0.0, 180.0)
    near += (
        (palette[1] - near) * draw_strands((near_n, near_n), fibres, rng.uniform(0.4, 0.9, n_fibres))[..., None] * fade
    )

    waves = []
    for _ in range(5):
        wavelength, direction = rng.uniform(150.0, 400.0), rng.uniform(0.0, 2 * math.pi)
        k = 2 * math.pi / wavelength
        waves.append(
            (k * math.cos(direction), k * math.sin(direction), rng.uniform(0, 2 * math.pi), rng.uniform(0.5, 1))
        )
    return DrapeCloth(
        near=ChartTexture(near.astype(np.float32), (-NEAR_HALF_MM, -NEAR_HALF_MM), near_texel_mm),
        far=ChartTexture(far.astype(np.float32), far_origin, FAR_TEXEL_MM),
        waves=[tuple(float(v) for v in w) for w in waves],
        palette_srgb=palette_srgb,
    )


def grid_axis() -> np.ndarray:
    """The drape mesh's grid lines (the same in x and y): 5 mm apart within 600 mm, then widening."""
    inner = np.arange(-600.0, 600.0 + 1e-9, 5.0)
    outer = 600.0 * np.geomspace(1.0, FAR_HALF_MM / 600.0, 25)[1:]
    return np.concatenate([-outer[::-1], inner, outer])


def drape_mesh(cloth: DrapeCloth, keep_flat_xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and faces of the drape; `keep_flat_xy` is a boolean raster (RASTER_MM cells over
    +-600 mm, row = y) of what lies on it (footprint and marker strip)."""
    free = np.where(keep_flat_xy, 0, 255).astype(np.uint8)
    distance = cv2.distanceTransform(free, cv2.DIST_L2, cv2.DIST_MASK_PRECISE) * RASTER_MM
    axis = grid_axis()
    x, y = np.meshgrid(axis, axis)
    u, v = (
        ((x.ravel() + 600.0) / RASTER_MM - 0.5).astype(np.float32),
        ((y.ravel() + 600.0) / RASTER_MM - 0.5).astype(np.float32),
    )
    inside = (np.abs(x.ravel()) < 598) & (np.abs(y.ravel()) < 598)
    dist = np.where(inside, sample_image(distance[..., None], u, v)[:, 0], 1e6)
    ramp = np.clip((dist - FLAT_MM) / RAMP_MM, 0.0, 1.0)
    ramp = ramp * ramp * (3 - 2 * ramp)
    total = sum(w for *_, w in cloth.waves)
    fold = sum(w * np.sin(kx * x.ravel() + ky * y.ravel() + ph) for kx, ky, ph, w in cloth.waves) / total
    z = FOLD_MM * 0.5 * (1.0 + fold) * ramp
    vertices = np.stack([x.ravel(), y.ravel(), z], 1)
    return vertices, grid_faces(len(axis), len(axis))


def describe(cloth: DrapeCloth) -> dict[str, Any]:
    return {
        "model": f"height field z = h(x, y) >= 0: {FOLD_MM:g} mm * (1 + weighted mean of 5 sinusoids) / 2, "
        f"flat (z = 0) within {FLAT_MM:g} mm of the body part's footprint and the marker strip, "
        f"ramping up over {RAMP_MM:g} mm; extends to +-{FAR_HALF_MM:g} mm",
        "waves_kx_ky_phase_weight": cloth.waves,
        "palette_srgb": cloth.palette_srgb,
    }


def raster_index(xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Row and column of world (x, y) points in the +-600 mm placement raster."""
    n = int(1200 / RASTER_MM)
    col = np.clip(((xy[:, 0] + 600.0) / RASTER_MM).astype(np.int64), 0, n - 1)
    row = np.clip(((xy[:, 1] + 600.0) / RASTER_MM).astype(np.int64), 0, n - 1)
    return row, col
