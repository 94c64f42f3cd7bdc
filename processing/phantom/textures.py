"""Texture building blocks: a texture over a chart in mm, smooth noise, and drawn dots and strands.

Textures live in a surface's own chart (or in world x, y for the drape), so a surface point has
the same colour in every view. Images are (rows, cols, 4) float32: linear RGB albedo and a
specular strength; texel (row j, col i) covers chart [p0 + i t, p0 + (i+1) t) x [q0 + j t, ...).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

_SHIFT = 4  # cv2 drawing with 4 fractional bits of sub-texel position


@dataclass(frozen=True)
class ChartTexture:
    image: np.ndarray
    """(rows, cols, 4) float32: linear RGB albedo, specular strength."""
    origin: tuple[float, float]
    """Chart (p, q) of the outer corner of texel (0, 0), mm."""
    texel_mm: float

    def texel_coords(self, p: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """cv2.remap coordinates (column, row) of chart points."""
        u = (np.asarray(p, np.float64) - self.origin[0]) / self.texel_mm - 0.5
        v = (np.asarray(q, np.float64) - self.origin[1]) / self.texel_mm - 0.5
        return u.astype(np.float32), v.astype(np.float32)

    def sample(self, p: np.ndarray, q: np.ndarray) -> np.ndarray:
        """Bilinear look-up of flat arrays of chart points: (K, 4)."""
        return sample_image(self.image, *self.texel_coords(p, q))


def sample_image(image: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Bilinear look-up of flat arrays of texel coordinates; clamps at the edges."""
    k = len(u)
    width = 4096  # cv2.remap maps must stay below 32767 on a side
    rows = max(1, -(-k // width))
    pad = rows * width - k
    mu = np.concatenate([u, np.zeros(pad, np.float32)]).reshape(rows, width)
    mv = np.concatenate([v, np.zeros(pad, np.float32)]).reshape(rows, width)
    out = cv2.remap(image, mu, mv, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    return out.reshape(rows * width, -1)[:k]


def texel_centres(
    shape: tuple[int, int],
    origin: tuple[float, float],
    texel_mm: float,
    window: tuple[int, int, int, int] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Chart coordinates (p, q) of texel centres, optionally of the window (row0, row1, col0, col1)."""
    r0, r1, c0, c1 = window or (0, shape[0], 0, shape[1])
    p = origin[0] + (np.arange(c0, c1) + 0.5) * texel_mm
    q = origin[1] + (np.arange(r0, r1) + 0.5) * texel_mm
    return np.meshgrid(p, q)


def smooth_noise(shape: tuple[int, int], sigma_px: float, rng: np.random.Generator) -> np.ndarray:
    """Gaussian-correlated noise of unit standard deviation with correlation length ~sigma_px texels.

    Made on a grid a few times finer than sigma and blurred there, then upsampled: the cost
    stays at one resize of the full texture whatever sigma is.
    """
    factor = max(1, int(sigma_px / 3.0))
    rows, cols = -(-shape[0] // factor) + 4, -(-shape[1] // factor) + 4
    coarse = rng.standard_normal((rows, cols)).astype(np.float32)
    sigma = sigma_px / factor
    coarse = cv2.GaussianBlur(coarse, (0, 0), sigma) if sigma >= 0.3 else coarse
    fine = cv2.resize(coarse, (cols * factor, rows * factor), interpolation=cv2.INTER_CUBIC)
    off = 2 * factor
    out = fine[off : off + shape[0], off : off + shape[1]]
    return (out - out.mean()) / max(float(out.std()), 1e-6)


def sigmoid(x: np.ndarray) -> np.ndarray:
    return 1.0 / (1.0 + np.exp(-x))


def srgb_to_linear(c) -> np.ndarray:
    c = np.asarray(c, dtype=np.float32)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4).astype(np.float32)


def draw_dots(shape: tuple[int, int], centres_px: np.ndarray, radii_px: np.ndarray, strength: np.ndarray) -> np.ndarray:
    """Anti-aliased filled discs; returns coverage times strength, float32 in [0, 1]."""
    canvas = np.zeros(shape, np.uint8)
    scale = 1 << _SHIFT
    for (x, y), r, a in zip(centres_px, radii_px, strength, strict=True):
        cv2.circle(
            canvas, (int(x * scale), int(y * scale)), max(1, int(r * scale)), int(255 * a), -1, cv2.LINE_AA, _SHIFT
        )
    return canvas.astype(np.float32) / 255.0


def draw_strands(shape: tuple[int, int], polylines_px: list[np.ndarray], strength: np.ndarray) -> np.ndarray:
    """Anti-aliased one-texel curves (hairs, threads): coverage times strength in [0, 1]."""
    canvas = np.zeros(shape, np.uint8)
    scale = 1 << _SHIFT
    for line, a in zip(polylines_px, strength, strict=True):
        cv2.polylines(canvas, [np.round(line * scale).astype(np.int32)], False, int(255 * a), 1, cv2.LINE_AA, _SHIFT)
    return canvas.astype(np.float32) / 255.0


def random_strands(
    rng: np.random.Generator,
    count: int,
    shape: tuple[int, int],
    length_px: tuple[float, float],
    angle_deg: float,
    spread_deg: float,
) -> list[np.ndarray]:
    """Gently curved strands of random length around a main direction."""
    start = rng.uniform([0, 0], [shape[1], shape[0]], size=(count, 2))
    length = rng.uniform(*length_px, size=count)
    angle = np.radians(angle_deg + rng.normal(0.0, spread_deg, size=count))
    bend = rng.normal(0.0, 0.25, size=count)
    steps = np.linspace(0.0, 1.0, 5)
    heading = angle[:, None] + bend[:, None] * steps[None, :]
    seg = (length / 4)[:, None]
    dx = np.cumsum(np.concatenate([np.zeros((count, 1)), (seg * np.cos(heading))[:, 1:]], 1), axis=1)
    dy = np.cumsum(np.concatenate([np.zeros((count, 1)), (seg * np.sin(heading))[:, 1:]], 1), axis=1)
    return [np.stack([start[i, 0] + dx[i], start[i, 1] + dy[i]], 1) for i in range(count)]
