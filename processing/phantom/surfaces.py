"""The body parts: parametric surfaces X(p, q) over a 2-D chart in mm, in the body part's own frame (z up).

`point` is written with complex-safe numpy only (no abs, max or clip on the coordinates), so
tangents come from complex-step differentiation, exact to rounding: the ground truth's normals
and area elements never depend on a finite-difference step. Each surface also says where on it
a burn may go and which part of the chart is smooth skin (the ends of the forearm and the rim of
the domes are for the picture only).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from typing import Any

import numpy as np

from processing.phantom.meshing import grid_faces, ring_mesh
from schemas.phantom import PhantomShape

_STEP = 1e-20


class Surface(ABC):
    shape: PhantomShape
    hair_angle_deg: float
    """Main hair direction in the chart, from the p axis."""
    hair_density_per_cm2: float

    @abstractmethod
    def point(self, p: np.ndarray, q: np.ndarray) -> np.ndarray:
        """(..., 3) surface points; complex-safe."""

    @abstractmethod
    def chart_bounds(self) -> tuple[float, float, float, float]:
        """p_min, p_max, q_min, q_max of the chart region that is rendered."""

    @abstractmethod
    def render_chart_mesh(self, spacing_mm: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Chart coordinates (p, q) of the render mesh's vertices and its faces."""

    @abstractmethod
    def smooth_skin(self, p: np.ndarray, q: np.ndarray) -> np.ndarray:
        """Where the chart describes smooth skin (the ground-truth surface is clipped to it)."""

    @abstractmethod
    def burn_allowed(self, p: np.ndarray, q: np.ndarray) -> np.ndarray:
        """Where a burn boundary may run: on top, away from the ends and steep sides."""

    @abstractmethod
    def burn_centre(self, rng: np.random.Generator) -> tuple[float, float]:
        """A chart point for the burn centre, on top of the body part."""

    @abstractmethod
    def describe(self) -> dict[str, Any]:
        """Parameters for the ground truth."""

    def tangents(self, p: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        p, q = np.asarray(p, np.float64), np.asarray(q, np.float64)
        return (self.point(p + 1j * _STEP, q).imag / _STEP, self.point(p, q + 1j * _STEP).imag / _STEP)

    def normal(self, p: np.ndarray, q: np.ndarray) -> np.ndarray:
        """Outward unit normal, X_p x X_q normalised."""
        xp, xq = self.tangents(p, q)
        n = np.cross(xp, xq)
        return n / np.linalg.norm(n, axis=-1, keepdims=True)

    def real_point(self, p: np.ndarray, q: np.ndarray) -> np.ndarray:
        with np.errstate(invalid="ignore"):
            return self.point(np.asarray(p, np.float64), np.asarray(q, np.float64)).real


def _signed(x: np.ndarray) -> np.ndarray:
    """|x| without abs (complex-step safe: the sign is decided by the real part)."""
    return np.where(np.real(x) >= 0, x, -x)


class Forearm(Surface):
    """Tapered elliptic cylinder along x, lying on z = 0, with rounded ends.

    Chart: p = rho * phi (phi = 0 at the bottom, pi on top, rho the mean semi-axis), q = x.
    """

    shape = PhantomShape.forearm
    hair_angle_deg = 90.0
    hair_density_per_cm2 = 1.6

    def __init__(self, rng: np.random.Generator):
        self.a = float(rng.uniform(40.0, 47.0))
        self.b = float(rng.uniform(32.0, 37.0))
        self.length = 240.0
        self.end_cap = 25.0
        self.taper = float(rng.uniform(0.08, 0.14))
        self.rho = 0.5 * (self.a + self.b)

    def point(self, p, q):
        phi = p / self.rho
        taper = 1.0 - self.taper * q / self.length
        u = (_signed(q) - (self.length / 2 - self.end_cap)) / self.end_cap
        cap = np.where(np.real(u) > 0, np.sqrt(1.0 - u * u + 0j), 1.0)
        if not np.iscomplexobj(p) and not np.iscomplexobj(q):
            cap = cap.real
        y = self.a * taper * cap * np.sin(phi)
        z = self.b * taper * (1.0 - cap * np.cos(phi))
        return np.stack([q + 0 * y, y, z], axis=-1)

    def chart_bounds(self):
        return 0.0, 2 * math.pi * self.rho, -self.length / 2, self.length / 2

    def render_chart_mesh(self, spacing_mm):
        p0, p1, q0, q1 = self.chart_bounds()
        cols = int(np.ceil((p1 - p0) / spacing_mm)) + 1  # first and last column coincide (the seam)
        rows = int(np.ceil((q1 - q0) / spacing_mm)) + 1
        p, q = np.meshgrid(np.linspace(p0, p1, cols), np.linspace(q0, q1, rows))
        return p.ravel(), q.ravel(), grid_faces(rows, cols)

    def smooth_skin(self, p, q):
        phi = p / self.rho
        return (np.abs(q) <= self.length / 2 - self.end_cap) & (phi > 0.1) & (phi < 2 * math.pi - 0.1)

    def burn_allowed(self, p, q):
        return (np.abs(p / self.rho - math.pi) < 1.35) & (np.abs(q) < self.length / 2 - self.end_cap - 8.0)

    def burn_centre(self, rng):
        return self.rho * (math.pi + float(rng.uniform(-0.25, 0.25))), float(rng.uniform(-25.0, 25.0))

    def describe(self):
        return {
            "shape": self.shape.value,
            "semi_axis_y_mm": self.a,
            "semi_axis_z_mm": self.b,
            "length_mm": self.length,
            "end_cap_mm": self.end_cap,
            "taper": self.taper,
            "model": "y = a(x) c(x) sin(phi), z = b(x) (1 - c(x) cos(phi)), a(x) = a (1 - taper x / length), "
            "b(x) likewise, c(x) the rounded-end profile (1 except within end_cap_mm of an end)",
            "chart": f"p = {self.rho:.6g} mm * phi (phi = 0 bottom, pi top), q = x",
        }


class HeightField(Surface):
    """A body part given as z = h(x, y) >= 0 over its footprint; chart p = x, q = y."""

    zc: float

    @abstractmethod
    def height(self, x, y):
        """Complex-safe height; negative outside the footprint."""

    @abstractmethod
    def domain_radius(self, psi: np.ndarray) -> np.ndarray:
        """Along direction psi in normalised (x / A, y / B) coordinates, where the height formula ends."""

    def point(self, p, q):
        return np.stack([p, q + 0 * p, self.height(p, q)], axis=-1)

    def _footprint_radius(self, psi: np.ndarray) -> np.ndarray:
        """Normalised radius where the surface meets z = 0, by bisection along each direction."""
        lo, hi = np.zeros_like(psi), self.domain_radius(psi) * (1 - 1e-12)
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            above = self.real_point(self.a * mid * np.cos(psi), self.b * mid * np.sin(psi))[..., 2] > 0
            lo, hi = np.where(above, mid, lo), np.where(above, hi, mid)
        return lo

    def chart_bounds(self):
        psi = np.linspace(0, 2 * math.pi, 720, endpoint=False)
        r = self._footprint_radius(psi)
        x, y = self.a * r * np.cos(psi), self.b * r * np.sin(psi)
        return float(x.min()) - 2, float(x.max()) + 2, float(y.min()) - 2, float(y.max()) + 2

    def render_chart_mesh(self, spacing_mm):
        # Rings following the footprint outline, the last exactly where the surface meets the drape.
        rings = np.linspace(0.0, 1.0, int(np.ceil(max(self.a, self.b) / spacing_mm)) + 1)
        counts = np.ceil(2 * math.pi * rings * max(self.a, self.b) / spacing_mm).astype(np.int64)
        mesh = ring_mesh(rings, np.maximum(counts, 6))
        r = mesh.s * self._footprint_radius(mesh.theta)
        return self.a * r * np.cos(mesh.theta), self.b * r * np.sin(mesh.theta), mesh.faces

    def smooth_skin(self, p, q):
        return self.real_point(p, q)[..., 2] > 1.0

    def burn_allowed(self, p, q):
        xp, xq = self.tangents(p, q)
        slope = np.hypot(xp[..., 2], xq[..., 2])
        return (self.real_point(p, q)[..., 2] > 15.0) & (slope < 1.2)


class Patch(HeightField):
    """A large, gently curved dome (thigh- or back-like): an ellipsoid cap with two broad swellings."""

    shape = PhantomShape.patch
    hair_density_per_cm2 = 0.8

    def __init__(self, rng: np.random.Generator):
        self.a, self.b = float(rng.uniform(125.0, 140.0)), float(rng.uniform(90.0, 100.0))
        self.c = float(rng.uniform(62.0, 75.0))
        self.zc = -self.c * float(rng.uniform(0.22, 0.32))
        self.swellings = [
            (
                float(rng.uniform(-50, 50)),
                float(rng.uniform(-35, 35)),
                float(rng.uniform(-3, 3)),
                float(rng.uniform(35, 55)),
            )
            for _ in range(2)
        ]
        self.hair_angle_deg = float(rng.uniform(60.0, 120.0))

    def height(self, x, y):
        inside = 1.0 - (x / self.a) ** 2 - (y / self.b) ** 2
        bumps = sum(
            amp * np.exp(-((x - cx) ** 2 + (y - cy) ** 2) / (2 * sig**2)) for cx, cy, amp, sig in self.swellings
        )
        return self.zc + self.c * np.sqrt(inside) + bumps * inside**2

    def domain_radius(self, psi):
        return np.ones_like(psi)

    def burn_centre(self, rng):
        return float(rng.uniform(-25.0, 25.0)), float(rng.uniform(-15.0, 15.0))

    def describe(self):
        return {
            "shape": self.shape.value,
            "semi_axes_mm": [self.a, self.b, self.c],
            "centre_z_mm": self.zc,
            "swellings": [{"x_mm": x, "y_mm": y, "amp_mm": a, "sigma_mm": s} for x, y, a, s in self.swellings],
            "model": "z = centre_z + c sqrt(w) + w^2 sum amp exp(-|xy - centre|^2 / (2 sigma^2)), "
            "w = 1 - (x/a)^2 - (y/b)^2; the part with z > 0",
            "chart": "p = x, q = y (height field)",
        }


class Foot(HeightField):
    """A boxy dome rising toward the ankle, with smooth bumps (the top of a foot)."""

    shape = PhantomShape.foot
    hair_angle_deg = 0.0
    hair_density_per_cm2 = 0.5

    def __init__(self, rng: np.random.Generator):
        self.a, self.b = float(rng.uniform(108.0, 120.0)), float(rng.uniform(52.0, 58.0))
        self.h = float(rng.uniform(48.0, 56.0))
        self.zc = -8.0
        self.slope = float(rng.uniform(0.1, 0.18))
        self.bumps = [
            (
                float(rng.uniform(-80, 80)),
                float(rng.uniform(-35, 35)),
                float(rng.choice([-1, 1]) * rng.uniform(3.0, 6.5)),
                float(rng.uniform(9, 18)),
            )
            for _ in range(8)
        ]

    def height(self, x, y):
        inside = 1.0 - (x / self.a) ** 4 - (y / self.b) ** 4
        bumps = sum(amp * np.exp(-((x - cx) ** 2 + (y - cy) ** 2) / (2 * sig**2)) for cx, cy, amp, sig in self.bumps)
        return self.zc + self.h * np.sqrt(inside) * (1.0 + self.slope * x / self.a) + bumps * inside**2

    def domain_radius(self, psi):
        return (np.cos(psi) ** 4 + np.sin(psi) ** 4) ** -0.25

    def burn_centre(self, rng):
        return float(rng.uniform(-35.0, 20.0)), float(rng.uniform(-8.0, 8.0))

    def describe(self):
        return {
            "shape": self.shape.value,
            "half_length_mm": self.a,
            "half_width_mm": self.b,
            "height_mm": self.h,
            "base_z_mm": self.zc,
            "slope": self.slope,
            "bumps": [{"x_mm": x, "y_mm": y, "amp_mm": a, "sigma_mm": s} for x, y, a, s in self.bumps],
            "model": "z = base_z + height sqrt(w) (1 + slope x / a) + w^2 sum amp exp(-|xy - centre|^2 / "
            "(2 sigma^2)), w = 1 - (x/a)^4 - (y/b)^4; the part with z > 0",
            "chart": "p = x, q = y (height field)",
        }


def make_surface(shape: PhantomShape, rng: np.random.Generator) -> Surface:
    return {PhantomShape.forearm: Forearm, PhantomShape.patch: Patch, PhantomShape.foot: Foot}[shape](rng)
