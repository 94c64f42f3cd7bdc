"""Coarse to fine: one pass over the region the analysis gives, a second over a square around the burn found.

The first pass sees the whole region small (`coarse_size`), so a burn larger than the expected region, or
away from its centre, is still found whole. The second pass looks again at `fine_size` on a square sized
to that burn, where its edge has several times more pixels. Both the training code (torch) and the
shipped model (onnxruntime) run through here, so the scores in the training report are the clinic's.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np

from schemas.segmentation import PassSettings

Network = Callable[[np.ndarray], np.ndarray]
"""float32 NCHW RGB in [0, 1] -> burn probability (N, H, W)."""

FINE_FILL = 0.6
"""The burn's extent as a share of the fine square's side (the middle of what training showed)."""
SPECK_SHARE = 0.1
"""Regions of the coarse mask smaller than this share of the largest are left out of the fine square."""


@dataclass(frozen=True)
class Square:
    """A square region of a picture in pixels: x0, y0 inclusive, side."""

    x0: int
    y0: int
    side: int

    @classmethod
    def around(cls, cx: float, cy: float, radius: float, width: int, height: int) -> Square:
        """The square of half-side radius centred on (cx, cy), moved (not shrunk) to fit in the picture."""
        side = int(max(1, min(2 * radius, width, height)))
        x0 = int(np.clip(round(cx - side / 2), 0, width - side))
        y0 = int(np.clip(round(cy - side / 2), 0, height - side))
        return cls(x0, y0, side)

    def cut(self, image: np.ndarray) -> np.ndarray:
        return image[self.y0 : self.y0 + self.side, self.x0 : self.x0 + self.side]


@dataclass(frozen=True)
class TwoPass:
    """What both passes saw and said; `probability` is the picture's, 0 outside the coarse region."""

    probability: np.ndarray
    coarse: np.ndarray
    """The first pass's probability alone over the region (the whole picture when region is None)."""
    fine_square: Square | None
    """Where the second pass looked (None: it did not run, no burn was found or it is switched off)."""
    region: Square | None = None
    """Where the first pass looked (None: the whole picture)."""

    def looked_at(self) -> tuple[slice, slice] | None:
        """Rows and columns of the rectangle around both passes' squares (None: the whole picture): the second
        square may reach past the first where the burn does."""
        if self.region is None:
            return None
        squares = [self.region] + ([self.fine_square] if self.fine_square else [])
        y0, x0 = min(q.y0 for q in squares), min(q.x0 for q in squares)
        y1, x1 = max(q.y0 + q.side for q in squares), max(q.x0 + q.side for q in squares)
        return slice(y0, y1), slice(x0, x1)

    def seen(self) -> np.ndarray:
        """True on the pixels either pass looked at."""
        if self.region is None:
            return np.ones(self.probability.shape, bool)
        out = np.zeros(self.probability.shape, bool)
        for square in (self.region, self.fine_square):
            if square is not None:
                square.cut(out)[:] = True
        return out


def rescaled(
    prob: np.ndarray, threshold: float, within: tuple[slice, slice] | None = None, in_place: bool = False
) -> np.ndarray:
    """Probability mapped piecewise linearly so the model's own threshold sits at 0.5: everything after
    the segmentation (fusion on the surface, the burn/no-burn cut at 0.5) then cuts where the model does.
    `within` (rows, columns; TwoPass.looked_at): only there can it be non-zero (0 stays 0), so only that
    part is mapped. in_place: prob itself is changed and returned (no copy of a whole picture)."""
    if threshold == 0.5:
        return prob
    out = prob if in_place else prob.copy()
    part = out if within is None else out[within]
    low_slope, high_slope = np.float32(0.5 / threshold), np.float32(0.5 / (1 - threshold))
    high = part * high_slope
    high += np.float32(0.5) - np.float32(threshold) * high_slope
    # the two lines meet at the threshold: the lower one below it where threshold < 0.5, the upper where above
    pick = np.minimum if threshold < 0.5 else np.maximum
    part *= low_slope
    pick(part, high, out=part)
    return out


def network_at(network: Network, rgb: np.ndarray, side: int) -> np.ndarray:
    """Probability for an RGB uint8 image resized to side x side, at that size."""
    x = cv2.resize(rgb, (side, side), interpolation=cv2.INTER_AREA)
    x = np.ascontiguousarray(x.transpose(2, 0, 1)[None], dtype=np.float32) / np.float32(255.0)
    return network(x)[0]


def run_network(network: Network, rgb: np.ndarray, side: int) -> np.ndarray:
    """Probability for an RGB uint8 image resized to side x side, resized back to the image's size."""
    h, w = rgb.shape[:2]
    return cv2.resize(network_at(network, rgb, side), (w, h), interpolation=cv2.INTER_LINEAR)


def burn_extent(mask: np.ndarray) -> tuple[int, int, int, int] | None:
    """Bounding box (x0, y0, x1, y1) of the mask's regions, specks left out; None when there is no burn."""
    count, _, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    if count < 2:
        return None
    areas = stats[1:, cv2.CC_STAT_AREA]
    keep = stats[1:][areas >= SPECK_SHARE * areas.max()]
    x0, y0 = keep[:, cv2.CC_STAT_LEFT].min(), keep[:, cv2.CC_STAT_TOP].min()
    x1 = (keep[:, cv2.CC_STAT_LEFT] + keep[:, cv2.CC_STAT_WIDTH]).max()
    y1 = (keep[:, cv2.CC_STAT_TOP] + keep[:, cv2.CC_STAT_HEIGHT]).max()
    return int(x0), int(y0), int(x1), int(y1)


def fine_square(
    mask: np.ndarray, looked: tuple[int, int, int, int], fine_size: int, shape: tuple[int, int]
) -> Square | None:
    """The square the second pass looks at, inside the picture of `shape`, around the burn the first pass
    found in `mask` (at the network's size); looked: (x0, y0, width, height) of the picture's part that
    mask covers."""
    extent = burn_extent(mask)
    if extent is None:
        return None
    lx, ly, lw, lh = looked
    sx, sy = lw / mask.shape[1], lh / mask.shape[0]
    x0, y0, x1, y1 = lx + extent[0] * sx, ly + extent[1] * sy, lx + extent[2] * sx, ly + extent[3] * sy
    h, w = shape
    radius = max(x1 - x0, y1 - y0, 8) / FINE_FILL / 2
    square = Square.around((x0 + x1) / 2, (y0 + y1) / 2, radius, w, h)
    if square.side >= 0.9 * max(lw, lh) and fine_size <= max(lw, lh):
        # the burn fills the region: a second pass would see the same pixels again
        return None
    return square


def segment(network: Network, rgb: np.ndarray, region: Square | None, settings: PassSettings) -> TwoPass:
    """Both passes over an RGB uint8 picture; `region` None means the whole picture (resized to a square)."""
    h, w = rgb.shape[:2]
    prob = np.zeros((h, w), np.float32)
    part = rgb if region is None else region.cut(rgb)
    looked = (0, 0, w, h) if region is None else (region.x0, region.y0, region.side, region.side)
    small = network_at(network, part, settings.coarse_size)
    window = prob if region is None else region.cut(prob)
    window[:] = cv2.resize(small, (part.shape[1], part.shape[0]), interpolation=cv2.INTER_LINEAR)
    coarse = window.copy()
    square = None
    if settings.fine_pass:
        square = fine_square(small >= settings.threshold, looked, settings.fine_size, (h, w))
    if square is not None:
        square.cut(prob)[:] = run_network(network, square.cut(rgb), settings.fine_size)
    return TwoPass(prob, coarse, square, region)
