"""The burn's true figures, each computed two independent ways.

1. Quadrature in the burn's polar chart (s, theta): Gauss-Legendre in s, the periodic trapezoid
   rule in theta (both converge spectrally on these smooth integrands), with area elements
   |Y_s x Y_theta| from the exact surface normals. The volume integrates the Jacobian of
   Z(s, theta, lam) = X - lam d n over the solid between the two surfaces.
2. A very fine triangle mesh of the burn (edges under 0.1 mm, far finer than the render mesh),
   summing flat triangles: no derivatives, no quadrature rule; the volume is the signed
   tetrahedron sum of the closed shell the two patches make (they share the boundary ring).

`size_burn` solves R0 so the cratered area is the requested one.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy.optimize import brentq

from processing.phantom.burn import Burn, displaced_point, reference_point, scaled
from processing.phantom.meshing import adaptive_ring_mesh, edge_lengths, triangle_areas
from processing.phantom.surfaces import Surface
from schemas.errors import InvalidInput

_H = 1e-6
"""Central-difference step in s and theta (both dimensionless): error ~1e-10, far below what is checked."""


def _partials(fn, s: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return (fn(s + _H, t) - fn(s - _H, t)) / (2 * _H), (fn(s, t + _H) - fn(s, t - _H)) / (2 * _H)


def _polar_nodes(n_s: int, n_theta: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    x, w = np.polynomial.legendre.leggauss(n_s)
    theta = 2 * math.pi * np.arange(n_theta) / n_theta
    s, t = np.meshgrid(0.5 * (x + 1.0), theta, indexing="ij")
    weights = np.broadcast_to((0.5 * w)[:, None] * (2 * math.pi / n_theta), s.shape)
    return s, t, weights


def displaced_area(surface: Surface, burn: Burn, n_s: int = 48, n_theta: int = 384) -> float:
    s, t, w = _polar_nodes(n_s, n_theta)
    ys, yt = _partials(lambda a, b: displaced_point(surface, burn, a, b), s, t)
    return float((np.linalg.norm(np.cross(ys, yt), axis=-1) * w).sum())


def quadrature(surface: Surface, burn: Burn, n_s: int = 96, n_theta: int = 1024) -> dict[str, Any]:
    s, t, w = _polar_nodes(n_s, n_theta)
    xs, xt = _partials(lambda a, b: reference_point(surface, burn, a, b), s, t)
    ys, yt = _partials(lambda a, b: displaced_point(surface, burn, a, b), s, t)
    ref_element = np.linalg.norm(np.cross(xs, xt), axis=-1)
    area = float((np.linalg.norm(np.cross(ys, yt), axis=-1) * w).sum())
    ref_area = float((ref_element * w).sum())
    depth = burn.displacement(s)
    mean_depth = float((depth * ref_element * w).sum() / ref_area)

    def push(a, b):  # the displacement vector d n
        return reference_point(surface, burn, a, b) - displaced_point(surface, burn, a, b)

    ds, dt = _partials(push, s, t)
    d_vec = push(s, t)
    lam, lam_w = np.polynomial.legendre.leggauss(3)  # the Jacobian is quadratic in lam: exact
    volume = 0.0
    for lk, wk in zip(0.5 * (lam + 1.0), 0.5 * lam_w, strict=True):
        jac = np.einsum("...i,...i->...", -d_vec, np.cross(xs - lk * ds, xt - lk * dt))
        volume += wk * float((np.abs(jac) * w).sum())

    n_perimeter = 8 * n_theta
    theta = 2 * math.pi * np.arange(n_perimeter) / n_perimeter
    one = np.ones_like(theta)
    tangent = reference_point(surface, burn, one, theta + _H) - reference_point(surface, burn, one, theta - _H)
    perimeter = float(np.linalg.norm(tangent / (2 * _H), axis=-1).sum() * 2 * math.pi / n_perimeter)
    return {
        "area_mm2": area,
        "ref_area_mm2": ref_area,
        "perimeter_mm": perimeter,
        "mean_depth_mm": mean_depth,
        "volume_mm3": volume,
        "max_depth_mm": float(burn.displacement(np.zeros(1))[0]),
        "n_s": n_s,
        "n_theta": n_theta,
        "n_perimeter": n_perimeter,
    }


def fine_mesh(surface: Surface, burn: Burn, edge_mm: float = 0.1) -> dict[str, Any]:
    mesh = adaptive_ring_mesh(lambda a, b: displaced_point(surface, burn, a, b), 1.0, edge_mm)
    centre = reference_point(surface, burn, np.zeros(1), np.zeros(1))[0]
    x = reference_point(surface, burn, mesh.s, mesh.theta) - centre
    y = displaced_point(surface, burn, mesh.s, mesh.theta) - centre
    ref_tri = triangle_areas(x, mesh.faces)
    depth = burn.displacement(mesh.s)

    def signed_volume(v):
        return float(
            np.einsum("ij,ij->i", v[mesh.faces[:, 0]], np.cross(v[mesh.faces[:, 1]], v[mesh.faces[:, 2]])).sum() / 6
        )

    ring = np.flatnonzero(mesh.s == 1.0)
    ring = ring[np.argsort(mesh.theta[ring])]
    boundary = x[ring]
    return {
        "area_mm2": float(triangle_areas(y, mesh.faces).sum()),
        "ref_area_mm2": float(ref_tri.sum()),
        "perimeter_mm": float(np.linalg.norm(np.roll(boundary, -1, axis=0) - boundary, axis=1).sum()),
        "mean_depth_mm": float((ref_tri * depth[mesh.faces].mean(axis=1)).sum() / ref_tri.sum()),
        "volume_mm3": abs(signed_volume(x) - signed_volume(y)),
        "max_depth_mm": float(np.linalg.norm(y - x, axis=1).max()),
        "vertices": len(mesh.s),
        "triangles": len(mesh.faces),
        "max_edge_mm": float(edge_lengths(y, mesh.faces).max()),
    }


def relative_difference(a: float, b: float) -> float:
    scale = max(abs(a), abs(b))
    return abs(a - b) / scale if scale > 0 else 0.0


def cross_checks(by_quadrature: dict[str, Any], by_mesh: dict[str, Any]) -> dict[str, Any]:
    checks: dict[str, Any] = {"fine_mesh": by_mesh, "quadrature": by_quadrature}
    for key, name in [
        ("area_mm2", "area_rel_diff_mesh_vs_quadrature"),
        ("ref_area_mm2", "ref_area_rel_diff"),
        ("perimeter_mm", "perimeter_rel_diff"),
        ("volume_mm3", "volume_rel_diff"),
        ("mean_depth_mm", "mean_depth_rel_diff"),
        ("max_depth_mm", "max_depth_rel_diff"),
    ]:
        checks[name] = relative_difference(by_quadrature[key], by_mesh[key])
    checks["max_depth_on_fine_grid_mm"] = by_mesh["max_depth_mm"]
    return checks


def largest_fitting_r0(surface: Surface, burn: Burn, r0_max: float) -> float:
    """The largest R0 (up to r0_max) whose boundary runs where the surface allows a burn; 0 if none."""
    theta = np.linspace(0.0, 2 * math.pi, 360, endpoint=False)

    def fits(r0: float) -> bool:
        return bool(surface.burn_allowed(*scaled(burn, r0, burn.depth_mm).chart_point(np.ones(360), theta)).all())

    if fits(r0_max):
        return r0_max
    lo, hi = 0.0, r0_max
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if fits(mid) else (lo, mid)
    return lo


def size_burn(surface: Surface, burn: Burn, area_mm2: float) -> Burn:
    """The burn with R0 chosen so that its displaced (cratered) area is `area_mm2`."""

    def excess(r0: float) -> float:
        return displaced_area(surface, scaled(burn, r0, burn.depth_mm)) - area_mm2

    lo = 0.5
    hi = largest_fitting_r0(surface, burn, 2.0 * math.sqrt(area_mm2 / math.pi))
    if hi <= lo or excess(hi) < 0:
        raise InvalidInput(f"a burn of {area_mm2 / 100:g} cm2 does not fit on this body part: ask for a smaller area")
    return scaled(burn, brentq(excess, lo, hi, xtol=1e-12, rtol=1e-14), burn.depth_mm)
