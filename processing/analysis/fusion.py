"""Fusing the views' probabilities per vertex into one burn probability.

Every rule takes p and w of shape (n_views, V), the sampled probabilities and visibility weights, and only
uses views with w > 0 (those that see the vertex). Vertices no view sees get NaN.
"""

from __future__ import annotations

import enum

import numpy as np

from schemas.errors import InvalidInput

LOGIT_EPS = 1e-3
"""Probabilities are clipped to [eps, 1 - eps] before the logit (|logit| <= 6.9), so one view saying a hard
0 or 1 cannot outvote every other view on its own."""


class FusionRule(enum.StrEnum):
    noisy_or = "noisy_or"
    weighted_mean = "weighted_mean"
    log_odds = "log_odds"


def views_per_vertex(w: np.ndarray) -> np.ndarray:
    """How many views see each vertex (weight > 0), (V,) int."""
    return np.count_nonzero(np.asarray(w) > 0, axis=0)


def noisy_or(p: np.ndarray, w: np.ndarray) -> np.ndarray:
    """1 - prod(1 - p) over the views that see a vertex: burnt unless every view says it is not.

    It saturates: ten views each saying 0.2 give 0.89, so many mildly positive views become a confident burn.
    """
    p, seen = _check(p, w)
    fused = 1.0 - np.prod(np.where(seen, 1.0 - p, 1.0), axis=0)
    return _unseen_nan(fused, seen)


def weighted_mean(p: np.ndarray, w: np.ndarray) -> np.ndarray:
    """sum(w p) / sum(w): the visibility-weighted average probability."""
    p, seen = _check(p, w)
    w = np.where(seen, w, 0.0)
    total = w.sum(axis=0)
    fused = np.divide((w * p).sum(axis=0), total, out=np.zeros_like(total), where=total > 0)
    return _unseen_nan(fused, seen)


def log_odds(p: np.ndarray, w: np.ndarray) -> np.ndarray:
    """sigmoid(sum(w logit p) / sum(w)): the weighted mean in log-odds, so confident views pull harder."""
    p, seen = _check(p, w)
    clipped = np.clip(p, LOGIT_EPS, 1.0 - LOGIT_EPS)
    w = np.where(seen, w, 0.0)
    total = w.sum(axis=0)
    mean = np.divide(
        (w * np.log(clipped / (1.0 - clipped))).sum(axis=0), total, out=np.zeros_like(total), where=total > 0
    )
    return _unseen_nan(1.0 / (1.0 + np.exp(-mean)), seen)


MIN_PAIR_VERTICES = 50
"""Two views whose burns together cover fewer shared vertices than this are not compared."""


def view_agreement(p: np.ndarray, w: np.ndarray, keep: np.ndarray) -> float | None:
    """Mean IoU between the burns (p >= 0.5) of every two views, over the vertices in `keep` both see:
    1 when each view outlines the same burn, low when they disagree where it ends. None with no pair."""
    seen = (np.asarray(w) > 0) & keep
    burn = (np.asarray(p) >= 0.5) & seen
    ious = []
    for i in range(len(p)):
        for j in range(i + 1, len(p)):
            both = seen[i] & seen[j]
            a, b = burn[i] & both, burn[j] & both
            union = int(np.count_nonzero(a | b))
            if union >= MIN_PAIR_VERTICES:
                ious.append(np.count_nonzero(a & b) / union)
    return round(float(np.mean(ious)), 4) if ious else None


_RULES = {FusionRule.noisy_or: noisy_or, FusionRule.weighted_mean: weighted_mean, FusionRule.log_odds: log_odds}


def fuse(rule: FusionRule | str, p: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Fused probability (V,) by the named rule; NaN where no view sees the vertex."""
    try:
        chosen = FusionRule(rule)
    except ValueError:
        raise InvalidInput(f"unknown fusion rule {rule!r}; use one of {', '.join(FusionRule)}") from None
    return _RULES[chosen](p, w)


def _check(p: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """p (0 where unseen) and the mask of views seeing each vertex; InvalidInput for mismatched or impossible input."""
    p, w = np.asarray(p, dtype=np.float64), np.asarray(w, dtype=np.float64)
    if p.ndim != 2 or p.shape != w.shape:
        raise InvalidInput(f"p and w must both have shape (n_views, V); got {p.shape} and {w.shape}")
    if not np.all(np.isfinite(w)) or np.any(w < 0):
        raise InvalidInput("weights must be finite and >= 0")
    seen = w > 0
    if not np.all(np.isfinite(p[seen])) or np.any(p[seen] < 0) or np.any(p[seen] > 1):
        raise InvalidInput("probabilities of seen vertices must be finite and in [0, 1]")
    return np.where(seen, p, 0.0), seen


def _unseen_nan(fused: np.ndarray, seen: np.ndarray) -> np.ndarray:
    return np.where(seen.any(axis=0), fused, np.nan)
