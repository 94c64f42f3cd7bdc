"""Held-out Dice by skin tone, with bootstrap 95 % intervals: real photos by ITA category, phantoms by
Fitzpatrick type. Pooled Dice (2 * sum of overlaps / sum of both masks' areas over a group's images) is
resampled over images, so one large wound weighs as much as it does in the point estimate.
"""

from __future__ import annotations

import numpy as np

from processing.segmentation import skin_tone
from schemas.segmentation import FairnessTable, GroupScore

MIN_IMAGES_FOR_INTERVAL = 5
"""A group with fewer held-out images gets no interval: resampling two or three images says nothing."""
METHOD = (
    "Skin tone of each held-out photo: the Individual Typology Angle (ITA°, Chardon 1991) of the healthy "
    "skin in a ring around the true wound outline, after a white-patch correction, grouped into the six "
    "categories of Del Bino 2006. Rendered phantoms: the Fitzpatrick type they were rendered with. Dice is "
    "pooled over each group's images; the 95 % interval is the 2.5th-97.5th percentile of {draws} "
    "bootstrap resamples of the group's images (seed {seed})."
)


def overlap(pred: np.ndarray, truth: np.ndarray) -> tuple[float, float]:
    """(overlap, sum of both areas) in pixels: what pooled Dice adds up."""
    return float(np.logical_and(pred, truth).sum()), float(pred.sum() + truth.sum())


def group_score(
    group: str,
    parts: list[tuple[float, float]],
    draws: int,
    rng: np.random.Generator,
    ita: list[float] | None = None,
) -> GroupScore:
    """Pooled Dice of a group's (overlap, total) pairs and its bootstrap 95 % interval."""
    if not parts:
        return GroupScore(group=group, images=0, dice_pooled=None, ci95_low=None, ci95_high=None)
    inter, total = np.array(parts, dtype=np.float64).T
    picks = rng.integers(0, len(parts), size=(draws, len(parts)))
    totals = total[picks].sum(axis=1)
    resampled = np.where(totals > 0, 2 * inter[picks].sum(axis=1) / np.maximum(totals, 1), 1.0)
    low, high = np.percentile(resampled, [2.5, 97.5]) if len(parts) >= MIN_IMAGES_FOR_INTERVAL else (None, None)
    return GroupScore(
        group=group,
        images=len(parts),
        dice_pooled=round(float(2 * inter.sum() / total.sum()) if total.sum() else 1.0, 4),
        ci95_low=None if low is None else round(float(low), 4),
        ci95_high=None if high is None else round(float(high), 4),
        ita_median=round(float(np.median(ita)), 1) if ita else None,
    )


def table(
    real: list[tuple[np.ndarray, np.ndarray, np.ndarray]],
    synthetic: list[tuple[str, np.ndarray, np.ndarray]],
    draws: int,
    seed: int,
) -> FairnessTable:
    """real: (rgb, predicted mask, true mask) per held-out photo; synthetic: (skin type, predicted, true)."""
    rng = np.random.default_rng(seed)
    by_category: dict[str, list[tuple[tuple[float, float], float]]] = {name: [] for name, _ in skin_tone.CATEGORIES}
    unknown = 0
    for rgb, pred, truth in real:
        ita = skin_tone.ita_degrees(rgb, truth)
        if ita is None:
            unknown += 1
            continue
        by_category[skin_tone.category(ita)].append((overlap(pred, truth), ita))
    by_type: dict[str, list[tuple[float, float]]] = {}
    for tone, pred, truth in synthetic:
        by_type.setdefault(tone, []).append(overlap(pred, truth))
    return FairnessTable(
        method=METHOD.format(draws=draws, seed=seed),
        real_by_ita=[
            group_score(name, [p for p, _ in rows], draws, rng, [i for _, i in rows])
            for name, rows in by_category.items()
        ],
        synthetic_by_fitzpatrick=[group_score(t, parts, draws, rng) for t, parts in sorted(by_type.items())],
        photos_without_skin_estimate=unknown,
    )
