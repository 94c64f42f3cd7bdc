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
    """The first pass's probability alone, at the picture's size."""
    fine_square: Square | None
    """Where the second pass looked (None: it did not run, no burn was found or it is switched off)."""


def rescaled(prob: np.ndarray, threshold: float, within: Square | None = None) -> np.ndarray:
    """Probability mapped piecewise linearly so the model's own threshold sits at 0.5: everything after
    the segmentation (fusion on the surface, the burn/no-burn cut at 0.5) then cuts where the model does.
    `within`: only that square can be non-zero (0 stays 0), so only it is mapped."""
    if threshold == 0.5:
        return prob
    if within is not None:
        out = prob.copy()
        within.cut(out)[:] = rescaled(within.cut(prob), threshold)
        return out
    out = prob * np.float32(0.5 / threshold)
    high = prob >= threshold
    out[high] = 0.5 + (prob[high] - threshold) * np.float32(0.5 / (1 - threshold))
    return out.astype(np.float32, copy=False)


def run_network(network: Network, rgb: np.ndarray, side: int) -> np.ndarray:
    """Probability for an RGB uint8 image resized to side x side, resized back to the image's size."""
    h, w = rgb.shape[:2]
    x = cv2.resize(rgb, (side, side), interpolation=cv2.INTER_AREA)
    x = np.ascontiguousarray(x.transpose(2, 0, 1)[None], dtype=np.float32) / np.float32(255.0)
    prob = network(x)[0]
    return cv2.resize(prob, (w, h), interpolation=cv2.INTER_LINEAR)


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


def fine_square(mask: np.ndarray, region: Square, fine_size: int, shape: tuple[int, int]) -> Square | None:
    """The square the second pass looks at, inside the picture of `shape`, around the burn the first pass
    found in `mask` (the region's own pixels)."""
    extent = burn_extent(mask)
    if extent is None:
        return None
    x0, y0, x1, y1 = (v + o for v, o in zip(extent, (region.x0, region.y0) * 2, strict=True))
    h, w = shape
    radius = max(x1 - x0, y1 - y0, 8) / FINE_FILL / 2
    square = Square.around((x0 + x1) / 2, (y0 + y1) / 2, radius, w, h)
    if square.side >= 0.9 * region.side and fine_size <= region.side:
        # the burn fills the region: a second pass would see the same pixels again
        return None
    return square


def segment(network: Network, rgb: np.ndarray, region: Square | None, settings: PassSettings) -> TwoPass:
    """Both passes over an RGB uint8 picture; `region` None means the whole picture (resized to a square)."""
    h, w = rgb.shape[:2]
    coarse = np.zeros((h, w), np.float32)
    if region is None:
        coarse[:] = run_network(network, rgb, settings.coarse_size)
        region = Square(0, 0, max(h, w))
    else:
        region.cut(coarse)[:] = run_network(network, region.cut(rgb), settings.coarse_size)
    found = region.cut(coarse) >= settings.threshold
    square = fine_square(found, region, settings.fine_size, (h, w)) if settings.fine_pass else None
    prob = coarse.copy()
    if square is not None:
        square.cut(prob)[:] = run_network(network, square.cut(rgb), settings.fine_size)
    return TwoPass(prob, coarse, square)
