"""Triangulating one point seen in several placed pictures, robustly."""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from processing.reconstruction.views import View

MAX_REPROJECTION_PX = 2.0


def triangulate(views: list[View], pixels: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """World point, per-observation reprojection errors (px), and indices of the observations kept.

    Linear (DLT) start, then a robust reprojection-error fit; observations more than 2 px off
    are dropped and the point is fitted again from the rest.
    """
    keep = list(range(len(views)))
    point = _dlt([views[i] for i in keep], [pixels[i] for i in keep])
    for _ in range(2):
        point = _refine(point, [views[i] for i in keep], [pixels[i] for i in keep])
        errors = reprojection_errors(point, views, pixels)
        inliers = [i for i in range(len(views)) if errors[i] < MAX_REPROJECTION_PX]
        if inliers == keep or len(inliers) < 2:
            break
        keep = inliers
    return point, reprojection_errors(point, views, pixels), keep


def reprojection_errors(point: np.ndarray, views: list[View], pixels: list[np.ndarray]) -> np.ndarray:
    errors = []
    for view, pixel in zip(views, pixels, strict=True):
        uv, z = view.project(point[None, :])
        errors.append(float(np.linalg.norm(uv[0] - pixel)) if z[0] > 0 else np.inf)
    return np.array(errors)


def _dlt(views: list[View], pixels: list[np.ndarray]) -> np.ndarray:
    rows = []
    for view, (u, v) in zip(views, pixels, strict=True):
        P = view.projection_matrix()
        rows += [u * P[2] - P[0], v * P[2] - P[1]]
    _, _, vt = np.linalg.svd(np.array(rows))
    return vt[-1, :3] / vt[-1, 3]


def _refine(point: np.ndarray, views: list[View], pixels: list[np.ndarray]) -> np.ndarray:
    observed = np.array(pixels).ravel()

    def residuals(x: np.ndarray) -> np.ndarray:
        return np.concatenate([view.project(x[None, :])[0][0] for view in views]) - observed

    return least_squares(residuals, point, loss="soft_l1", f_scale=0.5).x
