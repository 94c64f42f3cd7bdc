"""The burn: a star-shaped region of the surface chart, optionally a crater, and the surface it makes.

Boundary R(theta) = R0 (1 + sum a_k cos(k theta + phi_k)) around a chart centre; a chart point's
polar coordinate s = r / R(theta) is < 1 inside. The crater pushes the skin along the inward
normal by d = depth (1 - s^2)^2: deepest at the centre, zero with zero slope at the boundary,
so the displaced surface meets the undisplaced one smoothly there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from processing.phantom.surfaces import Surface

HARMONICS = range(2, 8)
MAX_WIGGLE = 0.35
"""Bound on sum |a_k|: the outline stays star-shaped and plausibly blob-like."""


@dataclass(frozen=True)
class Burn:
    centre: tuple[float, float]
    """Chart point (p, q) of the burn centre, mm."""
    r0_mm: float
    harmonics: tuple[tuple[int, float, float], ...]
    """(k, a_k, phi_k)."""
    depth_mm: float

    def radius(self, theta: np.ndarray) -> np.ndarray:
        return self.r0_mm * (1.0 + sum(a * np.cos(k * theta + phase) for k, a, phase in self.harmonics))

    def chart_point(self, s: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        r = s * self.radius(theta)
        return self.centre[0] + r * np.cos(theta), self.centre[1] + r * np.sin(theta)

    def polar(self, p: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(s, theta) of chart points."""
        dp, dq = p - self.centre[0], q - self.centre[1]
        theta = np.mod(np.arctan2(dq, dp), 2 * math.pi)
        return np.hypot(dp, dq) / self.radius(theta), theta

    def displacement(self, s: np.ndarray) -> np.ndarray:
        """Inward displacement d(s), mm."""
        s = np.asarray(s, dtype=np.float64)
        return np.where(s < 1.0, self.depth_mm * (1.0 - np.minimum(s, 1.0) ** 2) ** 2, 0.0)

    def describe(self) -> dict[str, Any]:
        return {
            "centre_chart_mm": list(self.centre),
            "R0_mm": self.r0_mm,
            "harmonics": [{"k": k, "amp": a, "phase": phase} for k, a, phase in self.harmonics],
            "depth_param_mm": self.depth_mm,
            "radius_function": "R(theta) = R0 (1 + sum amp cos(k theta + phase)), theta from the chart p axis",
            "depth_profile": "d = depth (1 - s^2)^2 along the inward normal, s = r / R(theta)",
        }


def random_outline(rng: np.random.Generator) -> tuple[tuple[int, float, float], ...]:
    amps = np.array([rng.uniform(-1.0, 1.0) * 0.22 / (k - 1) ** 1.1 for k in HARMONICS])
    amps *= min(1.0, MAX_WIGGLE / np.abs(amps).sum())
    return tuple((k, float(a), float(rng.uniform(0.0, 2 * math.pi))) for k, a in zip(HARMONICS, amps, strict=True))


def scaled(burn: Burn, r0_mm: float, depth_mm: float) -> Burn:
    return replace(burn, r0_mm=float(r0_mm), depth_mm=float(depth_mm))


def reference_point(surface: Surface, burn: Burn, s: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Undisplaced surface at polar chart coordinates (s, theta)."""
    s, theta = np.broadcast_arrays(np.asarray(s, np.float64), np.asarray(theta, np.float64))
    return surface.real_point(*burn.chart_point(s, theta))


def displaced_point(surface: Surface, burn: Burn, s: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Displaced (cratered) surface at polar chart coordinates (s, theta)."""
    s, theta = np.broadcast_arrays(np.asarray(s, np.float64), np.asarray(theta, np.float64))
    p, q = burn.chart_point(s, theta)
    d = burn.displacement(s)
    x = surface.real_point(p, q)
    if burn.depth_mm == 0.0:
        return x
    inside = s < 1.0
    out = x.copy()
    out[inside] -= d[inside, None] * surface.normal(p[inside], q[inside])
    return out
