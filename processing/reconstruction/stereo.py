"""CPU multi-view stereo: a depth map per picture by coarse plane sweep, then surface-following refinement.

Level 0 (quarter resolution) sweeps fronto-parallel planes across the region's depth range and
keeps, per pixel, the depth whose warped neighbours look most alike (NCC, best half of the
neighbours so one occluded view does not veto). Each finer level then searches a few depths
around the previous estimate; every pixel is warped at its own depth, so the comparison window
follows the curved skin instead of assuming a plane. A parabola through the best score gives the
sub-sample depth.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from processing.reconstruction.roi import Region
from processing.reconstruction.views import View

WINDOWS = {4: 5, 2: 7, 1: 11}
"""NCC window side per level (by downscale factor)."""
REFINE_SAMPLES = 9


@dataclass
class Picture:
    """A placed view with its undistorted grey image as float32, and a pyramid by downscale factor."""

    view: View
    pyramid: dict[int, np.ndarray]

    @classmethod
    def build(cls, view: View, gray: np.ndarray) -> Picture:
        image = view.undistort_image(gray).astype(np.float32) / 255.0
        h, w = image.shape
        image = image[: h // 4 * 4, : w // 4 * 4]  # exact halvings keep every level's pixels aligned
        pyramid = {1: image}
        for factor in (2, 4):
            prev = pyramid[factor // 2]
            pyramid[factor] = cv2.resize(prev, (prev.shape[1] // 2, prev.shape[0] // 2), interpolation=cv2.INTER_AREA)
        return cls(view, pyramid)

    def K(self, factor: int) -> np.ndarray:
        s = 1.0 / factor
        K = self.view.K.copy()
        K[:2, :2] *= s
        K[:2, 2] = (K[:2, 2] + 0.5) * s - 0.5
        return K


@dataclass
class DepthMap:
    """Depth along the reference camera's z axis for a crop of the full-resolution picture."""

    view: View
    x0: int
    y0: int
    depth: np.ndarray
    score: np.ndarray
    valid: np.ndarray


def depth_map(
    ref: Picture, sources: list[Picture], region: Region, planes: int, min_ncc: float, finest: int = 1
) -> DepthMap | None:
    box = region.pixel_box(ref.view)
    if box is None:
        return None
    near, far = region.depth_range(ref.view)
    # Crop in full-resolution pixels, aligned to the coarsest level.
    x0, y0 = int(box[0]) // 4 * 4, int(box[1]) // 4 * 4
    x1, y1 = (
        min(int(np.ceil(box[2])) // 4 * 4 + 4, ref.pyramid[4].shape[1] * 4),
        min(int(np.ceil(box[3])) // 4 * 4 + 4, ref.pyramid[4].shape[0] * 4),
    )
    depth, step, score = _sweep(ref, sources, (x0, y0, x1, y1), near, far, planes)
    factor = 4
    while factor > finest:
        factor //= 2
        shape = ((y1 - y0) // factor, (x1 - x0) // factor)
        prior = _smooth_fill(depth, score > min_ncc * 0.6)
        prior = cv2.resize(prior, shape[::-1], interpolation=cv2.INTER_LINEAR)
        step = cv2.resize(step, shape[::-1], interpolation=cv2.INTER_LINEAR)
        depth, step, score = _refine(ref, sources, factor, (x0, y0), prior, step)
    valid = (score >= min_ncc) & np.isfinite(depth) & (depth > near) & (depth < far)
    return DepthMap(ref.view, x0, y0, depth.astype(np.float32), score.astype(np.float32), valid)


def _relative(ref: View, src: View) -> tuple[np.ndarray, np.ndarray]:
    rotation = src.R @ ref.R.T
    return rotation, src.t - rotation @ ref.t


def _ncc_parts(image: np.ndarray, window: int) -> tuple[np.ndarray, np.ndarray]:
    mean = cv2.boxFilter(image, -1, (window, window))
    var = cv2.boxFilter(image * image, -1, (window, window)) - mean * mean
    return mean, np.maximum(var, 1e-6)


def _ncc(ref: np.ndarray, ref_mean: np.ndarray, ref_var: np.ndarray, warped: np.ndarray, window: int) -> np.ndarray:
    mean, var = _ncc_parts(warped, window)
    cov = cv2.boxFilter(ref * warped, -1, (window, window)) - ref_mean * mean
    ncc = cov / np.sqrt(ref_var * var)
    ncc[var < 2e-5] = -1.0  # textureless or outside the source picture
    return ncc


def _aggregate(scores: np.ndarray) -> np.ndarray:
    """Mean of the best half of the per-source scores (axis 0)."""
    keep = max(1, (scores.shape[0] + 1) // 2)
    return np.sort(scores, axis=0)[-keep:].mean(axis=0)


def _sweep(
    ref: Picture, sources: list[Picture], crop: tuple[int, int, int, int], near: float, far: float, planes: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    factor, window = 4, WINDOWS[4]
    x0, y0, x1, y1 = (c // factor for c in crop)
    image = ref.pyramid[factor][y0:y1, x0:x1]
    ref_mean, ref_var = _ncc_parts(image, window)
    K_ref = ref.K(factor)
    K_ref[:2, 2] -= (x0, y0)
    K_ref_inv = np.linalg.inv(K_ref)
    inverse = np.linspace(1.0 / near, 1.0 / far, planes)
    costs = np.full((planes, *image.shape), -1.0, dtype=np.float32)
    normal = np.array([0.0, 0.0, 1.0])
    # Per source, the plane homography is K_src (R + t n^T / d) K_ref^-1: only 1/d changes per plane.
    parts = []
    for src in sources:
        rotation, translation = _relative(ref.view, src.view)
        K_src = src.K(factor)
        parts.append((src, K_src @ rotation @ K_ref_inv, K_src @ np.outer(translation, normal) @ K_ref_inv))
    for i, inv_depth in enumerate(inverse):
        per_source = []
        for src, fixed, per_inverse_depth in parts:
            homography = fixed + per_inverse_depth * inv_depth
            warped = cv2.warpPerspective(
                src.pyramid[factor],
                homography,
                image.shape[::-1],
                flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
                borderValue=0.0,
            )
            per_source.append(_ncc(image, ref_mean, ref_var, warped, window))
        costs[i] = _aggregate(np.array(per_source))
    best = np.argmax(costs, axis=0)
    score = np.take_along_axis(costs, best[None], axis=0)[0]
    inv_best = inverse[best] + _parabola(costs, best) * (inverse[1] - inverse[0])
    depth = 1.0 / inv_best
    step = depth * depth * abs(inverse[1] - inverse[0])
    return depth.astype(np.float32), step.astype(np.float32), score


def _parabola(costs: np.ndarray, best: np.ndarray) -> np.ndarray:
    """Sub-sample offset of the maximum, in samples, from the scores either side."""
    n = costs.shape[0]
    lo, hi = np.clip(best - 1, 0, n - 1), np.clip(best + 1, 0, n - 1)
    c0 = np.take_along_axis(costs, lo[None], axis=0)[0]
    c1 = np.take_along_axis(costs, best[None], axis=0)[0]
    c2 = np.take_along_axis(costs, hi[None], axis=0)[0]
    denominator = c0 - 2 * c1 + c2
    with np.errstate(divide="ignore", invalid="ignore"):
        offset = np.where(denominator < -1e-6, 0.5 * (c0 - c2) / denominator, 0.0)
    offset[(best == 0) | (best == n - 1)] = 0.0
    return np.clip(offset, -0.5, 0.5)


def _refine(
    ref: Picture, sources: list[Picture], factor: int, origin: tuple[int, int], prior: np.ndarray, step: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    window = WINDOWS[factor]
    x0, y0 = origin[0] // factor, origin[1] // factor
    h, w = prior.shape
    image = ref.pyramid[factor][y0 : y0 + h, x0 : x0 + w]
    h, w = image.shape
    prior, step = prior[:h, :w], step[:h, :w]
    ref_mean, ref_var = _ncc_parts(image, window)
    K_ref = ref.K(factor)
    K_ref[:2, 2] -= (x0, y0)
    u, v = np.meshgrid(np.arange(w, dtype=np.float32), np.arange(h, dtype=np.float32))
    rays = np.stack([u, v, np.ones_like(u)], axis=-1) @ np.linalg.inv(K_ref).T.astype(np.float32)
    half = (REFINE_SAMPLES - 1) // 2
    spacing = 1.5 * step / half  # search +-1.5 previous steps
    costs = np.full((REFINE_SAMPLES, h, w), -1.0, dtype=np.float32)
    projected = []
    for src in sources:
        rotation, translation = _relative(ref.view, src.view)
        K_src = src.K(factor)
        projected.append(
            (src, (rays @ (K_src @ rotation).T.astype(np.float32)), (K_src @ translation).astype(np.float32))
        )
    for k in range(REFINE_SAMPLES):
        depth = prior + (k - half) * spacing
        per_source = []
        for src, direction, offset in projected:
            p = depth[..., None] * direction + offset
            with np.errstate(divide="ignore", invalid="ignore"):
                mx, my = p[..., 0] / p[..., 2], p[..., 1] / p[..., 2]
            warped = cv2.remap(
                src.pyramid[factor],
                mx.astype(np.float32),
                my.astype(np.float32),
                cv2.INTER_LINEAR,
                borderMode=cv2.BORDER_CONSTANT,
                borderValue=0.0,
            )
            per_source.append(_ncc(image, ref_mean, ref_var, warped, window))
        costs[k] = _aggregate(np.array(per_source))
    best = np.argmax(costs, axis=0)
    score = np.take_along_axis(costs, best[None], axis=0)[0]
    depth = prior + (best - half + _parabola(costs, best)) * spacing
    # At the edge of the search the true depth may lie beyond it: do not trust those pixels.
    score = np.where((best == 0) | (best == REFINE_SAMPLES - 1), -1.0, score)
    return depth.astype(np.float32), spacing.astype(np.float32), score


def _smooth_fill(depth: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Median-cleaned depth with holes filled from their surroundings (normalised convolution)."""
    d = np.where(valid, depth, 0.0).astype(np.float32)
    d = cv2.medianBlur(d, 5)
    weight = cv2.medianBlur(valid.astype(np.float32), 5)
    d = np.where(weight > 0.5, d, 0.0)
    weight = (weight > 0.5).astype(np.float32)
    blurred = cv2.GaussianBlur(d, (0, 0), 6)
    norm = cv2.GaussianBlur(weight, (0, 0), 6)
    fill = np.where(norm > 1e-3, blurred / np.maximum(norm, 1e-3), np.median(depth[valid]) if valid.any() else 1.0)
    return np.where(weight > 0, d, fill).astype(np.float32)
