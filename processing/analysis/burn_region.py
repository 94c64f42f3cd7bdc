"""The burn on a triangle mesh: area, boundary and perimeter of the region where a per-vertex probability >= 0.5.

The fused probability q is linear inside each triangle, so the burn boundary is a straight segment across
every triangle it passes through. Areas and integrals clip each triangle at that segment instead of counting
whole faces, so they depend on where the level lies, not on how finely the mesh is cut.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter1d

from schemas.errors import InvalidInput

LEVEL = 0.5


def check_mesh(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The mesh as float64 (V, 3) vertices and int64 (F, 3) faces; InvalidInput when it is not one."""
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces)
    if vertices.ndim != 2 or vertices.shape[1] != 3:
        raise InvalidInput(f"vertices must have shape (V, 3), got {vertices.shape}")
    if faces.ndim != 2 or faces.shape[1] != 3 or not np.issubdtype(faces.dtype, np.integer):
        raise InvalidInput(f"faces must be integer indices of shape (F, 3), got {faces.dtype} {faces.shape}")
    if not np.all(np.isfinite(vertices)):
        raise InvalidInput("vertices hold NaN or infinite coordinates")
    if len(faces) and (faces.min() < 0 or faces.max() >= len(vertices)):
        raise InvalidInput(f"faces index vertices outside 0..{len(vertices) - 1}")
    return vertices, faces.astype(np.int64)


def check_vertex_field(values: np.ndarray, n_vertices: int, name: str = "q") -> np.ndarray:
    """A per-vertex scalar field as float64 (V,); InvalidInput when its length does not match the mesh."""
    values = np.asarray(values, dtype=np.float64)
    if values.shape != (n_vertices,):
        raise InvalidInput(f"{name} must hold one value per vertex, shape ({n_vertices},), got {values.shape}")
    return values


def burn_vertex_mask(q: np.ndarray, level: float = LEVEL) -> np.ndarray:
    """Vertices in the burn: q >= level. Unseen vertices (NaN) are not burn."""
    q = np.asarray(q, dtype=np.float64)
    return np.isfinite(q) & (q >= level)


def level_offsets(q: np.ndarray, level: float = LEVEL) -> np.ndarray:
    """q - level with unseen vertices (NaN) taken as probability 0, so the boundary passes between them and burn."""
    return np.where(np.isfinite(q), q, 0.0) - level


def mesh_edges(faces: np.ndarray) -> np.ndarray:
    """The three edges of every face, (3F, 2) vertex pairs; an inner edge appears once from each side."""
    return np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])


def triangle_areas(corners: np.ndarray) -> np.ndarray:
    """Areas of triangles given as (T, 3, 3) corner coordinates."""
    return 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1)


def clip_above(corners: np.ndarray, a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The parts of triangles where the linear field `a` >= 0, as sub-triangles.

    corners (T, 3, D) carries any per-corner attributes (position and further fields), all interpolated
    linearly; a (T, 3) is the field at the corners. Returns the sub-triangles (T', 3, D), winding kept, and
    the index of the triangle each came from. One corner above gives one triangle, two give a quad (two
    triangles), three give the triangle itself.
    """
    above = a >= 0
    n_above = above.sum(axis=1)
    whole = n_above == 3
    parts, sources = [corners[whole]], [np.flatnonzero(whole)]
    for k in (1, 2):
        idx = np.flatnonzero(n_above == k)
        # Roll each triangle so the odd corner (the one on its own side) comes first; rolling keeps the winding.
        odd = np.argmax(above[idx], axis=1) if k == 1 else np.argmin(above[idx], axis=1)
        order = (odd[:, None] + np.arange(3)) % 3
        c = np.take_along_axis(corners[idx], order[:, :, None], axis=1)
        f = np.take_along_axis(a[idx], order, axis=1)
        # The level crossings on edges 0-1 and 0-2; denominators are non-zero as the ends lie on opposite sides.
        p1 = c[:, 0] + (f[:, 0] / (f[:, 0] - f[:, 1]))[:, None] * (c[:, 1] - c[:, 0])
        p2 = c[:, 0] + (f[:, 0] / (f[:, 0] - f[:, 2]))[:, None] * (c[:, 2] - c[:, 0])
        if k == 1:
            parts.append(np.stack([c[:, 0], p1, p2], axis=1))
            sources.append(idx)
        else:
            parts += [np.stack([p1, c[:, 1], c[:, 2]], axis=1), np.stack([p1, c[:, 2], p2], axis=1)]
            sources += [idx, idx]
    return np.concatenate(parts), np.concatenate(sources)


def burn_pieces(
    vertices: np.ndarray, faces: np.ndarray, q: np.ndarray, level: float = LEVEL, fields: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Sub-triangles covering the burn (q >= level) exactly, with columns 0-2 the position, then `fields`.

    fields (V, k) are further per-vertex values carried along (interpolated linearly). Returns (T', 3, 3 + k)
    and the source face of each sub-triangle.
    """
    vertices, faces = check_mesh(vertices, faces)
    q = check_vertex_field(q, len(vertices))
    attributes = (
        vertices if fields is None else np.hstack([vertices, np.asarray(fields, np.float64).reshape(len(vertices), -1)])
    )
    return clip_above(attributes[faces], level_offsets(q, level)[faces])


def per_face_burn_fraction(vertices: np.ndarray, faces: np.ndarray, q: np.ndarray, level: float = LEVEL) -> np.ndarray:
    """Share (F,) of each face's area where the interpolated q >= level (0 for degenerate faces)."""
    vertices, faces = check_mesh(vertices, faces)
    pieces, source = burn_pieces(vertices, faces, q, level)
    burnt = np.bincount(source, triangle_areas(pieces), minlength=len(faces))
    total = triangle_areas(vertices[faces])
    return np.divide(burnt, total, out=np.zeros_like(total), where=total > 0)


def burn_area_mm2(vertices: np.ndarray, faces: np.ndarray, q: np.ndarray, level: float = LEVEL) -> float:
    """Exact area of the surface where the linearly interpolated q >= level (mesh units squared: mm²)."""
    pieces, _ = burn_pieces(vertices, faces, q, level)
    return float(triangle_areas(pieces).sum())


def _crossings(vertices: np.ndarray, faces: np.ndarray, q: np.ndarray, level: float) -> tuple[np.ndarray, np.ndarray]:
    """Boundary segments (M, 2, 3), burn on their left seen from the normal side, and the mesh edge of each end.

    An end's edge is keyed as lo * V + hi of its sorted vertex pair, so the two faces sharing an edge give the
    same key to the same crossing.
    """
    vertices, faces = check_mesh(vertices, faces)
    a = level_offsets(check_vertex_field(q, len(vertices)), level)[faces]
    above = a >= 0
    n_above = above.sum(axis=1)
    idx = np.flatnonzero((n_above == 1) | (n_above == 2))
    single = n_above[idx] == 1
    odd = np.where(single, np.argmax(above[idx], axis=1), np.argmin(above[idx], axis=1))
    order = (odd[:, None] + np.arange(3)) % 3
    f = np.take_along_axis(faces[idx], order, axis=1)
    fa = np.take_along_axis(a[idx], order, axis=1)
    c = vertices[f]
    p1 = c[:, 0] + (fa[:, 0] / (fa[:, 0] - fa[:, 1]))[:, None] * (c[:, 1] - c[:, 0])
    p2 = c[:, 0] + (fa[:, 0] / (fa[:, 0] - fa[:, 2]))[:, None] * (c[:, 2] - c[:, 0])
    k1 = np.minimum(f[:, 0], f[:, 1]) * len(vertices) + np.maximum(f[:, 0], f[:, 1])
    k2 = np.minimum(f[:, 0], f[:, 2]) * len(vertices) + np.maximum(f[:, 0], f[:, 2])
    # With one corner burnt, walking p1 -> p2 keeps that corner on the left; with two, p2 -> p1 does.
    start, end = np.where(single[:, None], p1, p2), np.where(single[:, None], p2, p1)
    key_start, key_end = np.where(single, k1, k2), np.where(single, k2, k1)
    return np.stack([start, end], axis=1), np.stack([key_start, key_end], axis=1)


def boundary_segments(vertices: np.ndarray, faces: np.ndarray, q: np.ndarray, level: float = LEVEL) -> np.ndarray:
    """The iso-line q = level on the surface as straight segments (M, 2, 3), one per face it crosses."""
    return _crossings(vertices, faces, q, level)[0]


@dataclass(frozen=True)
class Polyline:
    """A chained piece of the burn boundary: points (n, 3); closed loops do not repeat their first point."""

    points: np.ndarray
    closed: bool


def boundary_loops(vertices: np.ndarray, faces: np.ndarray, q: np.ndarray, level: float = LEVEL) -> list[Polyline]:
    """The boundary segments chained into polylines: closed loops, and open ones where the mesh border cuts them."""
    segments, keys = _crossings(vertices, faces, q, level)
    nodes, ends = np.unique(keys, return_inverse=True)
    ends = ends.reshape(-1, 2)
    points = np.empty((len(nodes), 3))
    points[ends.ravel()] = segments.reshape(-1, 3)
    touching: list[list[int]] = [[] for _ in nodes]
    for s, (u, v) in enumerate(ends.tolist()):
        touching[u].append(s)
        touching[v].append(s)
    used = np.zeros(len(segments), dtype=bool)
    # Open chains first, from a node with one segment, so they are walked end to end.
    starts = [n for n in range(len(nodes)) if len(touching[n]) == 1] + [int(u) for u in ends[:, 0]]
    loops = []
    for first in starts:
        chain = _walk(first, ends, touching, used)
        if chain:
            closed = chain[-1] == chain[0] and len(chain) > 2
            loops.append(Polyline(points[chain[:-1] if closed else chain], closed))
    return loops


def _walk(node: int, ends: np.ndarray, touching: list[list[int]], used: np.ndarray) -> list[int]:
    """Nodes visited following unused segments from `node` until none is left; [] when none leaves it."""
    chain = [node]
    while True:
        nxt = next((s for s in touching[node] if not used[s]), None)
        if nxt is None:
            return chain if len(chain) > 1 else []
        used[nxt] = True
        u, v = ends[nxt]
        node = int(v if u == node else u)
        chain.append(node)


@dataclass(frozen=True)
class Perimeter:
    """Boundary length after smoothing. Small loops (specks, holes of a few mm²) are counted apart."""

    perimeter_mm: float
    n_loops: int
    largest_loop_mm: float
    small_loops_mm: float
    n_small_loops: int


STEP_MM = 0.5
"""Arc-length spacing the loops are resampled at before smoothing: finer than any edge detail that matters."""
SMOOTHING_MM = 2.0
"""Width (two Gaussian sigmas) of the smoothing along a loop. The iso-line zigzags across triangles ~0.5-1 mm
wide and the probability maps resolve about a pixel (~0.5 mm at 25-30 cm); that jitter adds length that is
not in the wound edge. 2 mm removes it while shrinking a 10 mm-radius loop by only ~0.5 % (sigma²/2r²)."""
SMALL_SHARE = 0.01
"""A loop shorter than this share of all boundary length is small."""
SMALL_AREA_MM2 = 3.0
"""A closed loop enclosing less than this (a ~2 mm disc) is small: a speck or a pinhole, not a wound edge."""


def perimeter_mm(loops: list[Polyline], smoothing_mm: float = SMOOTHING_MM, step_mm: float = STEP_MM) -> Perimeter:
    """Total smoothed length of the boundary loops, small loops reported separately (see SMALL_*)."""
    if smoothing_mm < 0 or step_mm <= 0:
        raise InvalidInput(f"smoothing_mm must be >= 0 and step_mm > 0, got {smoothing_mm} and {step_mm}")
    lengths = np.array([_length(smooth_polyline(p, smoothing_mm, step_mm)) for p in loops])
    total = float(lengths.sum())
    small = np.array(
        [
            lengths[i] < SMALL_SHARE * total or (p.closed and enclosed_area(p.points) < SMALL_AREA_MM2)
            for i, p in enumerate(loops)
        ],
        dtype=bool,
    )
    main = lengths[~small]
    return Perimeter(
        perimeter_mm=float(main.sum()),
        n_loops=int(main.size),
        largest_loop_mm=float(main.max()) if main.size else 0.0,
        small_loops_mm=float(lengths[small].sum()),
        n_small_loops=int(small.sum()),
    )


def enclosed_area(points: np.ndarray) -> float:
    """Area spanned by a closed loop (norm of its vector area; the plane area when the loop is planar)."""
    p = points - points.mean(axis=0)
    return float(0.5 * np.linalg.norm(np.cross(p, np.roll(p, -1, axis=0)).sum(axis=0)))


def smooth_polyline(line: Polyline, smoothing_mm: float = SMOOTHING_MM, step_mm: float = STEP_MM) -> Polyline:
    """The polyline resampled every step_mm of arc length and Gaussian-smoothed (sigma = smoothing_mm / 2).

    Closed loops are smoothed periodically; open ones are mirrored through their ends so straight ends stay
    put. Loops shorter than ~8 sigma get a smaller sigma so they do not collapse to a point.
    """
    pts = np.vstack([line.points, line.points[:1]]) if line.closed else line.points
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    if len(pts) < 2 or arc[-1] == 0 or smoothing_mm == 0:
        return line
    n = max(int(np.ceil(arc[-1] / step_mm)), 4)
    s = np.linspace(0.0, arc[-1], n, endpoint=not line.closed)
    res = np.stack([np.interp(s, arc, pts[:, k]) for k in range(3)], axis=1)
    sigma = min(0.5 * smoothing_mm / (arc[-1] / n), n / 8)
    if line.closed:
        return Polyline(gaussian_filter1d(res, sigma, axis=0, mode="wrap"), True)
    pad = min(int(4 * sigma) + 1, n - 1)
    ext = np.vstack([2 * res[0] - res[pad:0:-1], res, 2 * res[-1] - res[-2 : -pad - 2 : -1]])
    return Polyline(gaussian_filter1d(ext, sigma, axis=0, mode="nearest")[pad : pad + n], False)


def _length(line: Polyline) -> float:
    pts = np.vstack([line.points, line.points[:1]]) if line.closed else line.points
    return float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())
