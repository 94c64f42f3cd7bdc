"""Triangle meshes over 2-D charts: concentric rings (polar charts) and regular grids.

A ring mesh samples a star-shaped chart region in polar form (s, theta): ring i at s_i with
its own number of points, so every edge stays near the requested length from the centre out,
and a ring at s = 1 lies exactly on the region's boundary. Triangles are counter-clockwise
in the chart, so with n = X_p x X_q they face out of the surface.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

ChartMap = Callable[[np.ndarray, np.ndarray], np.ndarray]
"""(s, theta) arrays -> (..., 3) surface points."""


@dataclass(frozen=True)
class RingMesh:
    s: np.ndarray
    """Per-vertex polar radius (0 at the centre, 1 on the boundary ring)."""
    theta: np.ndarray
    """Per-vertex polar angle in [0, 2 pi)."""
    faces: np.ndarray
    """(M, 3) int64 vertex indices, counter-clockwise in the chart."""


def _stitch(a0: int, m: int, b0: int, n: int) -> np.ndarray:
    """Triangles between an inner ring (m points from index a0) and an outer ring (n points from b0).

    Both rings start at theta 0 and are evenly spaced; walking both in angle order, each step
    advances one ring and makes one triangle.
    """
    alpha = np.arange(1, m + 1) / m
    beta = np.arange(1, n + 1) / n
    angles = np.concatenate([alpha, beta])
    is_inner = np.concatenate([np.ones(m, bool), np.zeros(n, bool)])
    order = np.lexsort((~is_inner, angles))
    is_inner = is_inner[order]
    i = np.cumsum(is_inner) - is_inner
    j = np.cumsum(~is_inner) - ~is_inner
    ai, ai1 = a0 + i % m, a0 + (i + 1) % m
    bj, bj1 = b0 + j % n, b0 + (j + 1) % n
    tris = np.where(is_inner[:, None], np.stack([ai, bj, ai1], 1), np.stack([ai, bj, bj1], 1))
    if m == 1:
        tris = tris[~is_inner]
    return tris


def ring_mesh(ring_s: np.ndarray, ring_counts: np.ndarray) -> RingMesh:
    """Mesh of rings at radii `ring_s` (increasing; a first radius of 0 is the single centre point)."""
    counts = np.where(ring_s == 0.0, 1, ring_counts).astype(np.int64)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    s = np.repeat(ring_s, counts)
    theta = np.concatenate([2 * np.pi * np.arange(c) / c for c in counts])
    faces = [_stitch(starts[k], counts[k], starts[k + 1], counts[k + 1]) for k in range(len(ring_s) - 1)]
    return RingMesh(s=s, theta=theta, faces=np.concatenate(faces).astype(np.int64))


def adaptive_ring_mesh(
    chart: ChartMap,
    s_max: float,
    edge_mm: float,
    *,
    ring_at_one: bool = True,
    keep: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
) -> RingMesh:
    """Ring mesh of (s, theta) in [0, s_max] x [0, 2 pi) whose surface edges are about `edge_mm` or shorter.

    Ring spacing follows the surface's radial stretch |dX/ds| and each ring's point count its
    tangential stretch |dX/dtheta|, both measured on a probe grid and only where `keep` says the
    mesh will be kept; with `ring_at_one`, s = 1 is one of the rings.
    """
    probe_s = np.linspace(0.0, s_max, 65)[1:]
    probe_t = np.linspace(0.0, 2 * np.pi, 721)[:-1]
    ss, tt = np.meshgrid(probe_s, probe_t, indexing="ij")
    h = 1e-5
    d_s = np.linalg.norm(chart(ss + h, tt) - chart(ss - h, tt), axis=-1) / (2 * h)
    d_t = np.linalg.norm(chart(ss, tt + h) - chart(ss, tt - h), axis=-1) / (2 * h)
    if keep is not None:
        dropped = ~keep(ss, tt)
        d_s[dropped], d_t[dropped] = np.nan, np.nan
    # Stretch per ring (NaN: nothing kept there); a ring takes the larger of its two probe neighbours.
    with np.errstate(invalid="ignore"):
        radial = np.fmax(np.nanmax(np.where(np.isnan(d_s), -np.inf, d_s), axis=1), 0.0)
        tangential = np.fmax(np.nanmax(np.where(np.isnan(d_t), -np.inf, d_t), axis=1), 0.0)
    radial = np.maximum(radial, np.concatenate([radial[1:], radial[-1:]]))
    floor = 1e-3 * max(radial.max(), 1e-9)
    # Radial steps a little shorter than tangential ones keep the stitching diagonals within budget.
    steps = 0.7 * edge_mm / (1.05 * np.maximum(radial, floor))
    marks = [0.0, 1.0, s_max] if ring_at_one and s_max > 1.0 else [0.0, s_max]
    ring_s = [0.0]
    for a, b in zip(marks, marks[1:], strict=False):
        grid = [a]
        while grid[-1] < b:
            grid.append(grid[-1] + float(np.interp(grid[-1], probe_s, steps)))
        # spread the steps evenly so the last ring lands exactly on b
        ring_s.extend(a + (b - a) * (np.array(grid[1:]) - a) / (grid[-1] - a))
    ring_s = np.array(ring_s)
    circumference = np.interp(ring_s, np.concatenate([[0.0], probe_s]), np.concatenate([[0.0], tangential]))
    counts = np.maximum(6, np.ceil(1.05 * 2 * np.pi * circumference / (0.7 * edge_mm))).astype(np.int64)
    return ring_mesh(ring_s, counts)


def grid_faces(rows: int, cols: int) -> np.ndarray:
    """Two triangles per cell of a rows x cols vertex grid (row-major), counter-clockwise in (col, row)."""
    idx = np.arange(rows * cols).reshape(rows, cols)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, d = idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    return np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)]).astype(np.int64)


def triangle_areas(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    v0, v1, v2 = vertices[faces[:, 0]], vertices[faces[:, 1]], vertices[faces[:, 2]]
    return 0.5 * np.linalg.norm(np.cross(v1 - v0, v2 - v0), axis=1)


def edge_lengths(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    return np.concatenate(
        [np.linalg.norm(vertices[faces[:, (k + 1) % 3]] - vertices[faces[:, k]], axis=1) for k in range(3)]
    )


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted vertex normals (unit; zero where no face has area)."""
    v0, v1, v2 = vertices[faces[:, 0]], vertices[faces[:, 1]], vertices[faces[:, 2]]
    face_n = np.cross(v1 - v0, v2 - v0)
    normals = np.stack(
        [sum(np.bincount(faces[:, k], face_n[:, axis], len(vertices)) for k in range(3)) for axis in range(3)], axis=1
    )
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    return np.divide(normals, length, out=np.zeros_like(normals), where=length > 0)


def compact(vertices_keep: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Faces whose three vertices are all kept, renumbered; and the kept vertices' old indices."""
    faces = faces[vertices_keep[faces].all(axis=1)]
    old = np.flatnonzero(vertices_keep)
    new_index = np.full(len(vertices_keep), -1, dtype=np.int64)
    new_index[old] = np.arange(len(old))
    return new_index[faces], old
