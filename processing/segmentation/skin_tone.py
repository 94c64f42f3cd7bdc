"""Skin tone of a photo from the healthy skin around the wound: the Individual Typology Angle (ITA°).

ITA = arctan((L* - 50) / b*) in degrees, from CIELAB (Chardon et al., Int J Cosmet Sci 1991), grouped
into the six published categories (Del Bino et al., 2006): very light > 55°, light 41-55°, intermediate
28-41°, tan 10-28°, brown -30-10°, dark < -30°. It is measured on a ring of skin beyond the wound's edge,
after a white-patch correction of exposure and colour cast, keeping only skin-coloured pixels (drapes,
gauze, shadows and glare are left out), and says nothing when too little skin is visible. From an
uncalibrated phone photo it is an estimate: lighting still moves it by a category or so.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

CATEGORIES = [
    ("very light", 55.0),
    ("light", 41.0),
    ("intermediate", 28.0),
    ("tan", 10.0),
    ("brown", -30.0),
    ("dark", -math.inf),
]
"""(name, lowest ITA of the category) from the lightest down."""
MIN_SKIN_PIXELS = 150
"""Fewer skin-coloured pixels in the ring than this (at the photo's resolution) give no estimate."""


def category(ita: float) -> str:
    """The ITA category an angle falls in."""
    return next(name for name, low in CATEGORIES if ita > low)


def surrounding_ring(mask: np.ndarray) -> np.ndarray:
    """Pixels beyond the wound's edge: from a gap of 15 % to 60 % of the wound's equivalent diameter."""
    area = float(mask.sum())
    diameter = 2 * math.sqrt(area / math.pi)
    gap = int(np.clip(0.15 * diameter, 3, 60))
    reach = int(np.clip(0.6 * diameter, gap + 8, 160))
    m = mask.astype(np.uint8)
    outer = cv2.dilate(m, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * reach + 1, 2 * reach + 1)))
    inner = cv2.dilate(m, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * gap + 1, 2 * gap + 1)))
    return (outer > 0) & (inner == 0)


def skin_lab(rgb: np.ndarray, where: np.ndarray) -> np.ndarray:
    """CIELAB (L*, a*, b*) of the skin-coloured pixels among `where`, as an (n, 3) array."""
    lab = cv2.cvtColor(rgb.astype(np.float32) / 255.0, cv2.COLOR_RGB2LAB)[where]
    lightness, a, b = lab[:, 0], lab[:, 1], lab[:, 2]
    hue = np.degrees(np.arctan2(b, a))
    chroma = np.hypot(a, b)
    skin = (lightness > 10) & (lightness < 95) & (chroma >= 6) & (hue >= 15) & (hue <= 85)
    return lab[skin]


def white_patch(rgb: np.ndarray) -> np.ndarray:
    """The photo with each channel scaled so its 99th percentile is white (gain at most 3): a phone's
    exposure and white balance otherwise move ITA more than skin does. Black padding is left out."""
    lit = rgb[rgb.max(axis=2) > 8]
    if len(lit) == 0:
        return rgb
    top = np.percentile(lit, 99, axis=0).clip(255 / 3, 255)
    return np.clip(rgb.astype(np.float32) * (255.0 / top), 0, 255).astype(np.uint8)


def ita_degrees(rgb: np.ndarray, mask: np.ndarray) -> float | None:
    """ITA° of the healthy skin around the wound in an RGB uint8 photo; None where too little skin shows
    (no wound, or the ring is mostly drape, dressing or background)."""
    if not mask.any():
        return None
    lab = skin_lab(white_patch(rgb), surrounding_ring(mask.astype(bool)))
    if len(lab) < MIN_SKIN_PIXELS:
        return None
    lightness, b = float(np.median(lab[:, 0])), float(np.median(lab[:, 2]))
    return round(math.degrees(math.atan2(lightness - 50.0, b)), 1)
