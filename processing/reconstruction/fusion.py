"""Fusing depth maps: keep depths that other pictures' depth maps confirm, as oriented, coloured points."""

from __future__ import annotations

import numpy as np

from processing.reconstruction.stereo import DepthMap

RELATIVE_TOLERANCE = 0.002
"""Two depth maps agree on a point when their depths differ by less than this share of the depth."""


def backproject(dm: DepthMap, stride: int = 1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World points, unit normals (towards the camera) and their (row, col) in the crop, for valid pixels."""
    h, w = dm.depth.shape
    u, v = np.meshgrid(np.arange(w) + dm.x0, np.arange(h) + dm.y0)
    K_inv = np.linalg.inv(dm.view.K)
    rays = np.stack([u, v, np.ones_like(u)], axis=-1).astype(np.float64) @ K_inv.T
    cam = rays * dm.depth[..., None]
    du = np.gradient(cam, axis=1)
    dv = np.gradient(cam, axis=0)
    normals = np.cross(du, dv)
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True) + 1e-12
    facing = np.sum(normals * cam, axis=-1) > 0
    normals[facing] *= -1
    mask = dm.valid.copy()
    if stride > 1:
        sub = np.zeros_like(mask)
        sub[::stride, ::stride] = True
        mask &= sub
    rows, cols = np.nonzero(mask)
    world = (cam[rows, cols] - dm.view.t) @ dm.view.R
    world_normals = normals[rows, cols] @ dm.view.R
    return world, world_normals, np.stack([rows, cols], axis=1)


def agreement(points: np.ndarray, others: list[DepthMap]) -> np.ndarray:
    """How many of `others` see each point at the depth they measured themselves."""
    count = np.zeros(len(points), dtype=np.int32)
    for dm in others:
        uv, z = dm.view.project(points)
        col = np.round(uv[:, 0]).astype(np.int64) - dm.x0
        row = np.round(uv[:, 1]).astype(np.int64) - dm.y0
        h, w = dm.depth.shape
        inside = (z > 0) & (col >= 0) & (col < w) & (row >= 0) & (row < h)
        idx = np.nonzero(inside)[0]
        measured = dm.depth[row[idx], col[idx]]
        ok = dm.valid[row[idx], col[idx]] & (np.abs(measured - z[idx]) < RELATIVE_TOLERANCE * z[idx])
        count[idx[ok]] += 1
    return count


def fuse(
    maps: list[DepthMap], colours: dict[str, np.ndarray], min_agree: int, stride: int = 2
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points, normals and RGB colours (0-1) confirmed by at least `min_agree` other depth maps."""
    all_points, all_normals, all_colours = [], [], []
    for i, dm in enumerate(maps):
        points, normals, pixels = backproject(dm, stride)
        others = [m for j, m in enumerate(maps) if j != i]
        keep = agreement(points, others) >= min_agree
        image = colours[dm.view.name]
        rgb = image[pixels[keep, 0] + dm.y0, pixels[keep, 1] + dm.x0][:, ::-1] / 255.0
        all_points.append(points[keep])
        all_normals.append(normals[keep])
        all_colours.append(rgb)
    if not all_points:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3))
    return np.vstack(all_points), np.vstack(all_normals), np.vstack(all_colours)
