"""The printed scale marker: three DICT_4X4_50 markers on a white strip lying flat beside the body part.

Strip coordinates (a, b) in mm run along the printed image's columns and rows; seen from above
the print reads normally, so OpenCV's corner order (top-left, top-right, bottom-right,
bottom-left of the marker image) maps to world corners directly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from processing.phantom.drape import RASTER_MM
from processing.phantom.textures import ChartTexture, smooth_noise, srgb_to_linear
from schemas.errors import InvalidInput

DICTIONARY = "DICT_4X4_50"
SIDE_MM = 20.0
GAP_MM = 5.0
MARGIN_MM = 6.0
THICKNESS_MM = 0.15
"""The paper lies on the flat drape (z = 0); its printed face is this high."""
TEXEL_MM = 0.05
PAPER_SRGB, INK_SRGB = 0.92, 0.08


@dataclass(frozen=True)
class MarkerStrip:
    ids: tuple[int, int, int]
    origin: np.ndarray
    """World point of strip coordinate (0, 0): the print's top-left corner."""
    e_a: np.ndarray
    """World direction of increasing a (the print's columns)."""
    e_b: np.ndarray
    """World direction of increasing b (the print's rows)."""

    @property
    def size_mm(self) -> tuple[float, float]:
        return 3 * SIDE_MM + 2 * GAP_MM + 2 * MARGIN_MM, SIDE_MM + 2 * MARGIN_MM

    def world(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return self.origin + np.multiply.outer(a, self.e_a) + np.multiply.outer(b, self.e_b)

    def corners(self) -> dict[int, np.ndarray]:
        out = {}
        for k, marker_id in enumerate(self.ids):
            a0 = MARGIN_MM + k * (SIDE_MM + GAP_MM)
            a = np.array([a0, a0 + SIDE_MM, a0 + SIDE_MM, a0])
            b = np.array([MARGIN_MM, MARGIN_MM, MARGIN_MM + SIDE_MM, MARGIN_MM + SIDE_MM])
            out[marker_id] = self.world(a, b)
        return out

    def quad(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Vertices, faces (facing up) and strip coordinates of the printed face."""
        w, h = self.size_mm
        ab = np.array([[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]])
        faces = np.array([[0, 2, 1], [0, 3, 2]])
        vertices = self.world(ab[:, 0], ab[:, 1])
        v0, v1, v2 = vertices[faces[0]]
        if np.cross(v1 - v0, v2 - v0)[2] < 0:
            faces = faces[:, ::-1]
        return vertices, faces, ab

    def describe(self) -> dict[str, Any]:
        return {
            "dictionary": DICTIONARY,
            "ids": list(self.ids),
            "side_mm": SIDE_MM,
            "gap_mm": GAP_MM,
            "white_margin_mm": MARGIN_MM,
            "strip_size_mm": list(self.size_mm),
            "placement": f"flat on the drape, printed face {THICKNESS_MM} mm above z = 0",
            "corner_order": "OpenCV ArUco order: top-left, top-right, bottom-right, bottom-left of the marker "
            "image (as seen from above)",
            "corners_world_mm": {str(i): c.tolist() for i, c in self.corners().items()},
        }


def strip_texture(ids: tuple[int, int, int], rng: np.random.Generator) -> ChartTexture:
    dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, DICTIONARY))
    px = int(round(1.0 / TEXEL_MM))
    width, height = (int(round(v * px)) for v in (3 * SIDE_MM + 2 * GAP_MM + 2 * MARGIN_MM, SIDE_MM + 2 * MARGIN_MM))
    print_ = np.full((height, width), 255, np.uint8)
    side = int(round(SIDE_MM * px))
    for k, marker_id in enumerate(ids):
        bits = cv2.aruco.generateImageMarker(dictionary, marker_id, 6, borderBits=1)
        x0, y0 = int(round((MARGIN_MM + k * (SIDE_MM + GAP_MM)) * px)), int(round(MARGIN_MM * px))
        print_[y0 : y0 + side, x0 : x0 + side] = cv2.resize(bits, (side, side), interpolation=cv2.INTER_NEAREST)
    paper, ink = srgb_to_linear([PAPER_SRGB, INK_SRGB])
    ink_cover = (print_ < 128).astype(np.float32)
    albedo = (paper + (ink - paper) * ink_cover) * (1.0 + 0.02 * smooth_noise((height, width), 4.0, rng))
    image = np.stack([albedo, albedo, albedo, np.full_like(albedo, 0.03)], -1).astype(np.float32)
    return ChartTexture(image=image, origin=(0.0, 0.0), texel_mm=TEXEL_MM)


def choose_ids(rng: np.random.Generator) -> tuple[int, int, int]:
    a, b, c = (int(i) for i in rng.choice(50, size=3, replace=False))
    return a, b, c


def place_strip(
    ids: tuple[int, int, int], footprint: np.ndarray, burn_xy: np.ndarray, axis_xy: np.ndarray, rng: np.random.Generator
) -> MarkerStrip:
    """Beside the body part, 15-40 mm from its footprint, roughly level with the burn.

    `footprint` is the boolean placement raster of the body part; `axis_xy` its long axis.
    The strip runs along the body part, on a random side.
    """
    free = np.where(footprint, 0, 255).astype(np.uint8)
    distance = cv2.distanceTransform(free, cv2.DIST_L2, cv2.DIST_MASK_PRECISE) * RASTER_MM
    gap = rng.uniform(15.0, 40.0)
    side = np.array([-axis_xy[1], axis_xy[0]]) * rng.choice([-1.0, 1.0])
    turn = math.radians(rng.uniform(-25.0, 25.0))
    out_dir = np.array(
        [math.cos(turn) * side[0] - math.sin(turn) * side[1], math.sin(turn) * side[0] + math.cos(turn) * side[1]]
    )
    along = np.array([out_dir[1], -out_dir[0]])  # the strip's long side, so its print faces away from the body
    w, h = 3 * SIDE_MM + 2 * GAP_MM + 2 * MARGIN_MM, SIDE_MM + 2 * MARGIN_MM
    a, b = np.meshgrid(np.linspace(0, w, 42), np.linspace(0, h, 17))
    for step in np.arange(0.0, 400.0, 1.0):
        centre = burn_xy + out_dir * step
        origin = centre - along * w / 2 - out_dir * h / 2
        pts = origin + np.multiply.outer(a.ravel(), along) + np.multiply.outer(b.ravel(), out_dir)
        col, row = ((pts + 600.0) / RASTER_MM).astype(np.int64).T
        if (col.min() < 0) or (row.min() < 0) or (col.max() >= free.shape[1]) or (row.max() >= free.shape[0]):
            break
        if distance[row, col].min() >= gap:
            # print rows (b) point toward the body part, so the strip reads upright from the far side
            e_b = np.array([*-out_dir, 0.0])
            e_a = np.array([*along, 0.0])
            if np.cross(e_a, e_b)[2] > 0:  # seen from above the print must not be mirrored
                e_a = -e_a
            start = np.array([*(centre - e_a[:2] * w / 2 - e_b[:2] * h / 2), THICKNESS_MM])
            return MarkerStrip(ids=ids, origin=start, e_a=e_a, e_b=e_b)
    raise InvalidInput("no room for the marker strip beside the body part")
