"""Dice and IoU of predicted against true masks, pooled and per image."""

from __future__ import annotations

import numpy as np

from schemas.segmentation import SplitScores


def dice_iou(pred: np.ndarray, truth: np.ndarray) -> tuple[float, float]:
    """Per-image Dice and IoU; both 1 when neither mask has any burn."""
    inter = float(np.logical_and(pred, truth).sum())
    total = float(pred.sum() + truth.sum())
    union = total - inter
    if total == 0:
        return 1.0, 1.0
    return 2 * inter / total, inter / union


def split_scores(pairs: list[tuple[np.ndarray, np.ndarray]]) -> SplitScores:
    """Scores of (prediction, truth) boolean mask pairs."""
    if not pairs:
        return SplitScores(images=0, dice_pooled=None, iou_pooled=None, dice_mean=None, iou_mean=None)
    inter = sum(float(np.logical_and(p, t).sum()) for p, t in pairs)
    total = sum(float(p.sum() + t.sum()) for p, t in pairs)
    per = np.array([dice_iou(p, t) for p, t in pairs])
    return SplitScores(
        images=len(pairs),
        dice_pooled=round(2 * inter / total, 4) if total else 1.0,
        iou_pooled=round(inter / (total - inter), 4) if total else 1.0,
        dice_mean=round(float(per[:, 0].mean()), 4),
        iou_mean=round(float(per[:, 1].mean()), 4),
    )
