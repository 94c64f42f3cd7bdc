"""Hand-computable surfaces, synthetic pinhole cameras and rendered burn probability maps for the surface tests.

Each surface is a grid in a 2D chart (mm) mapped onto 3D, with faces wound so normals point to +z at the chart
origin (towards the cameras). `chart_of` maps world points back to the chart, so a burn drawn in the chart
(a disc of radius r around the origin) can be rendered into any view by ray casting.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import open3d as o3d
from scipy.special import erfc

from processing.reconstruction.views import View

W, H, F = 640, 480, 600.0


@dataclass(frozen=True)
class Surface:
    vertices: np.ndarray
    faces: np.ndarray
    chart: np.ndarray
    chart_of: Callable[[np.ndarray], np.ndarray]


def grid(half_u: float, half_v: float, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Chart points (V, 2) on a regular grid and its triangles, counter-clockwise in (u, v)."""
    nu, nv = round(2 * half_u / step) + 1, round(2 * half_v / step) + 1
    u, v = np.meshgrid(np.linspace(-half_u, half_u, nu), np.linspace(-half_v, half_v, nv))
    idx = np.arange(nu * nv).reshape(nv, nu)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return np.stack([u.ravel(), v.ravel()], 1), faces


def sheet(half: float = 50.0, step: float = 1.0, height: Callable | None = None) -> Surface:
    """The plane z = height(x, y) (0 by default) over a square, charted by (x, y)."""
    chart, faces = grid(half, half, step)
    z = np.zeros(len(chart)) if height is None else height(chart[:, 0], chart[:, 1])
    return Surface(np.column_stack([chart, z]), faces, chart, lambda p: p[:, :2])


def crater(depth: float, radius: float, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """-D (1 - s²)² inside the disc s = rho / r < 1, 0 outside: a smooth pit with a flat rim."""
    s2 = (x * x + y * y) / radius**2
    return np.where(s2 < 1, -depth * (1 - s2) ** 2, 0.0)


def cylinder(radius: float = 40.0, half_arc: float = 60.0, half_height: float = 50.0, step: float = 1.0) -> Surface:
    """Part of a cylinder along y through the origin, axis at z = -radius, charted by (arc length, y)."""
    chart, faces = grid(half_arc, half_height, step)
    theta = chart[:, 0] / radius
    vertices = np.column_stack([radius * np.sin(theta), chart[:, 1], radius * np.cos(theta) - radius])

    def chart_of(p: np.ndarray) -> np.ndarray:
        return np.column_stack([radius * np.arctan2(p[:, 0], p[:, 2] + radius), p[:, 1]])

    return Surface(vertices, faces, chart, chart_of)


def sphere_cap(radius: float = 60.0, half: float = 45.0, step: float = 1.0) -> Surface:
    """Part of a sphere centred at z = -radius, charted by geodesic polar coordinates about the top."""
    chart, faces = grid(half, half, step)
    rho, phi = np.linalg.norm(chart, axis=1), np.arctan2(chart[:, 1], chart[:, 0])
    alpha = rho / radius
    vertices = radius * np.column_stack([np.sin(alpha) * np.cos(phi), np.sin(alpha) * np.sin(phi), np.cos(alpha)])
    vertices[:, 2] -= radius

    def chart_of(p: np.ndarray) -> np.ndarray:
        c = p + [0.0, 0.0, radius]
        a = np.arccos(np.clip(c[:, 2] / np.linalg.norm(c, axis=1), -1, 1))
        ph = np.arctan2(c[:, 1], c[:, 0])
        return radius * a[:, None] * np.column_stack([np.cos(ph), np.sin(ph)])

    return Surface(vertices, faces, chart, chart_of)


def look_at(name: str, centre: np.ndarray, target: np.ndarray) -> View:
    """A 640x480 pinhole camera (fx = fy = 600) at `centre` looking at `target`."""
    z = (target - centre) / np.linalg.norm(target - centre)
    helper = np.array([0.0, 1.0, 0.0]) if abs(z[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    R = np.stack([x, np.cross(z, x), z])
    K = np.array([[F, 0.0, (W - 1) / 2], [0.0, F, (H - 1) / 2], [0.0, 0.0, 1.0]])
    return View(name=name, image_id=0, width=W, height=H, K=K, dist=np.zeros(5), R=R, t=-R @ centre)


def cone_views(n: int = 6, tilt_deg: float = 30.0, distance: float = 270.0) -> list[View]:
    """n cameras on a cone about +z around the origin, all aimed at the origin."""
    tilt = np.radians(tilt_deg)
    views = []
    for i, az in enumerate(np.linspace(0, 2 * np.pi, n, endpoint=False)):
        c = distance * np.array([np.sin(tilt) * np.cos(az), np.sin(tilt) * np.sin(az), np.cos(tilt)])
        views.append(look_at(f"v{i}", c, np.zeros(3)))
    return views


def disc_probability(chart_of: Callable, radius: float, edge_mm: float) -> Callable[[np.ndarray], np.ndarray]:
    """Soft burn probability of world points: a chart disc blurred by a Gaussian edge (0.5 exactly on the circle)."""
    return lambda p: 0.5 * erfc((np.linalg.norm(chart_of(p), axis=1) - radius) / (np.sqrt(2) * edge_mm))


def render(vertices: np.ndarray, faces: np.ndarray, view: View, prob_of: Callable) -> np.ndarray:
    """The view's probability map: each pixel's ray hits the mesh, the hit point's probability is the pixel's."""
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(vertices.astype(np.float32)), o3d.core.Tensor(faces.astype(np.uint32)))
    u, v = np.meshgrid(np.arange(view.width, dtype=np.float64), np.arange(view.height, dtype=np.float64))
    cam = np.stack([u.ravel(), v.ravel(), np.ones(u.size)], 1) @ np.linalg.inv(view.K).T
    dirs = cam @ view.R
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    rays = np.hstack([np.broadcast_to(view.centre, dirs.shape), dirs]).astype(np.float32)
    t = scene.cast_rays(o3d.core.Tensor(rays))["t_hit"].numpy().astype(np.float64)
    hit = np.isfinite(t)
    prob = np.zeros(u.size)
    prob[hit] = prob_of(view.centre + t[hit, None] * dirs[hit])
    return prob.reshape(view.height, view.width).astype(np.float32)


def render_views(mesh: Surface, views: list[View], prob_of: Callable) -> list[np.ndarray]:
    """Every view's probability map of the burn drawn on `mesh`."""
    return [render(mesh.vertices, mesh.faces, v, prob_of) for v in views]
