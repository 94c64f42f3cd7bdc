"""Per-view evidence on how sure the model's outline is, computed from the picture and its two passes.

Each figure is kept raw in the view's record and summed up (median over the views) in the confidence
record; processing/analysis/confidence.py turns them into the score and the reasons.

- pass disagreement: 1 - Dice between the first pass (whole region, small) and the final mask. A burn
  the first pass cut in half, or one the closer look grew or shrank a lot, shows here.
- uncertain band: how wide, in the model's own pixels, the band of probability between 0.3 and 0.7
  runs along the outline. A sharp edge is about a pixel wide; a hesitant one several.
- outline contrast: CIELAB colour difference (Delta E 1976) between a band just inside the outline and
  one just outside. Where burn and skin look alike, the outline is a guess whatever the model says.
- skin tone: ITA of the healthy skin around the burn (processing/segmentation/skin_tone.py).
"""

from __future__ import annotations

import cv2
import numpy as np

from processing.segmentation import skin_tone
from processing.segmentation.passes import Square, TwoPass

TONE_SIDE = 512
"""The region is looked at this size for skin tone, as the held-out photos the model was scored on."""
CONTRAST_BAND = 0.04
"""Width of the bands either side of the outline, as a share of the region's side."""


def pass_disagreement(two: TwoPass, threshold: float) -> float | None:
    """1 - Dice of the first pass's mask against the final one; None when the second pass did not run."""
    if two.fine_square is None:
        return None
    first = two.coarse >= threshold  # 0 outside the region
    in_region = two.probability if two.region is None else two.region.cut(two.probability)
    window = two.looked_at()
    final_sum = np.count_nonzero((two.probability if window is None else two.probability[window]) >= threshold)
    total = float(np.count_nonzero(first) + final_sum)
    if total == 0:
        return None
    return round(1 - 2 * float(np.count_nonzero(first & (in_region >= threshold))) / total, 4)


def uncertain_band_px(prob: np.ndarray, threshold: float, model_px: float) -> float | None:
    """Mean width of the 0.3-0.7 band (around the threshold) along the outline, in model pixels;
    model_px is how many picture pixels one model pixel covers. None without a burn."""
    low, high = threshold * 0.6, 1 - (1 - threshold) * 0.6
    mask = (prob >= threshold).astype(np.uint8)
    contours, _ = cv2.findContours(mask, cv2.RETR_LIST, cv2.CHAIN_APPROX_NONE)
    length = sum(cv2.arcLength(c, closed=True) for c in contours)
    if length < 8:
        return None
    band = float(np.count_nonzero((prob >= low) & (prob < high)))
    return round(band / length / model_px, 2)


def outline_contrast(rgb: np.ndarray, mask: np.ndarray) -> float | None:
    """Delta E 1976 between the median CIELAB colour just inside and just outside the outline."""
    if mask.sum() < 50 or mask.all():
        return None
    band = max(2, int(CONTRAST_BAND * max(mask.shape)))
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * band + 1, 2 * band + 1))
    m = mask.astype(np.uint8)
    inside = m.astype(bool) & ~cv2.erode(m, kernel).astype(bool)
    outside = cv2.dilate(m, kernel).astype(bool) & ~m.astype(bool)
    if inside.sum() < 20 or outside.sum() < 20:
        return None
    lab = cv2.cvtColor(rgb.astype(np.float32) / 255.0, cv2.COLOR_RGB2LAB)
    return round(float(np.linalg.norm(np.median(lab[inside], axis=0) - np.median(lab[outside], axis=0))), 2)


def view_checks(rgb: np.ndarray, two: TwoPass, threshold: float, box: Square | None, model_side: int) -> dict:
    """The raw indicators of one view, as ViewMask fields, judged in the second pass's square, else the
    region the model looked at, else the whole picture."""
    square = two.fine_square or box
    if square is None:
        prob, crop, side = two.probability, rgb, max(rgb.shape[:2])
    else:
        prob, crop, side = square.cut(two.probability), square.cut(rgb), square.side
    mask = (prob >= threshold).astype(np.uint8)
    small = cv2.resize(crop, (TONE_SIDE, TONE_SIDE), interpolation=cv2.INTER_AREA)
    small_mask = cv2.resize(mask, (TONE_SIDE, TONE_SIDE), interpolation=cv2.INTER_NEAREST).astype(bool)
    return {
        "pass_disagreement": pass_disagreement(two, threshold),
        "uncertain_band_px": uncertain_band_px(prob, threshold, side / model_side),
        "outline_contrast": outline_contrast(small, small_mask),
        "skin_ita": skin_tone.ita_degrees(small, small_mask),
    }
