"""Smooth models of healthy skin, z = f(x, y) in a local frame, fitted robustly to the ring of skin around a burn
so they can stand in for the skin the burn has replaced.

Polynomials (plane, quadratic, quartic) follow a limb's curvature. Skin over tendons and bones (the back of the
foot or hand, the shin, the wrist) also carries parallel ridges: on the independent foot phantoms they stand
+-1 mm about 12 mm apart, and no polynomial through the ring can know where they run under the burn (it guessed
the relief 0.8-1.6 mm too deep there). The "ridged" model adds to the quartic a profile across the ridges (a
cubic B-spline in u, the coordinate across them) whose level may change linearly along them (v). A ridge that
crosses the burn is seen in the ring on both sides of it, so the profile carries it across.

Which model stands in for the skin is decided by how well each predicts ring skin it was not fitted to
(`holdout_error_mm`): the ring is cut into angular sectors and each is predicted from the others.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from schemas.errors import InvalidInput

Kind = Literal["ridged", "quartic", "quadratic", "plane"]
POLY_COLUMNS = {"plane": 3, "quadratic": 6, "quartic": 15}
HUBER_K = 1.345
"""Huber's constant: 95 % efficiency on Gaussian noise, while hair, dressing edges or unseen blisters in the ring
are down-weighted."""
MIN_SCALE_MM = 0.01
"""Floor on the robust residual scale so an exact fit does not divide by zero."""
RIDGE_KNOT_MM = 3.0
"""Knot spacing of the across-ridge profile: a tendon's ridge is 5-10 mm wide."""
RIDGE_SMOOTHING = 0.05
"""Weight of the penalty on second differences of the profile's coefficients (per 1000 ring points); it also
carries the profile smoothly over knots that no ring point constrains."""
RIDGE_ALONG_MM = 20.0
"""v is divided by this in the along-ridge term so its columns are sized like the others."""
SEARCH_STEP_DEG, REFINE_STEP_DEG = 10.0, 2.0
HOLDOUT_SECTORS = 8
THIN_CELL_MM = 0.7
"""The ring is thinned to one vertex per cell of this size before the ridged fit: the fit's cost grows with the
points, its accuracy does not (a reconstructed mesh has ~0.4 mm cells)."""
MAX_FIT_POINTS = 2500
"""...and to at most about this many (larger cells for a large ring): each of the ~90 least-squares solves of a
ridged fit and its hold-out test then takes milliseconds, not a fraction of a second, on a loaded 2-core box."""
MIN_RIDGED_POINTS = 100
"""Fewer ring points than this cannot pin down a ridge profile (tens of coefficients) on top of a quartic."""
TOLERANCE_MM = 1e-5
"""IRLS stops when no prediction at a ring point moves by more than this."""


@dataclass(frozen=True)
class SkinModel:
    """A fitted model; `height` evaluates it. ridge_deg and knots only for the ridged kind."""

    kind: Kind
    coefficients: np.ndarray
    ridge_deg: float | None = None
    knots: np.ndarray | None = None

    def height(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return design(self.kind, x, y, self.ridge_deg, self.knots) @ self.coefficients


def polynomial_design(x: np.ndarray, y: np.ndarray, columns: int = 15) -> np.ndarray:
    """Monomials up to degree 4, by degree: 1, x, y, x², xy, y², x³, x²y, xy², y³, x⁴, ... (first `columns`)."""
    x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
    return np.stack([x ** (n - j) * y**j for n in range(5) for j in range(n + 1)], axis=-1)[..., :columns]


def design(
    kind: Kind, x: np.ndarray, y: np.ndarray, ridge_deg: float | None = None, knots: np.ndarray | None = None
) -> np.ndarray:
    if kind != "ridged":
        return polynomial_design(x, y, POLY_COLUMNS[kind])
    if ridge_deg is None or knots is None:
        raise InvalidInput("a ridged skin model needs its ridge direction and knots")
    angle = math.radians(ridge_deg)
    u = math.cos(angle) * np.asarray(x) + math.sin(angle) * np.asarray(y)
    v = -math.sin(angle) * np.asarray(x) + math.cos(angle) * np.asarray(y)
    profile = _cubic_bspline(u, knots)
    return np.concatenate([polynomial_design(x, y), profile, profile * (v / RIDGE_ALONG_MM)[..., None]], axis=-1)


def fit(
    kind: Kind, loc: np.ndarray, ridge_deg: float | None = None, knots: np.ndarray | None = None, iterations: int = 30
) -> SkinModel:
    """Huber IRLS of z on the model's design; scale from the MAD of the residuals."""
    matrix = design(kind, loc[:, 0], loc[:, 1], ridge_deg, knots)
    if len(loc) < POLY_COLUMNS.get(kind, 15):
        raise InvalidInput(
            f"a {kind} reference needs at least {POLY_COLUMNS.get(kind, 15)} ring vertices, got {len(loc)}"
        )
    penalty = _penalty(matrix.shape[1], len(knots), len(loc)) if kind == "ridged" else np.zeros((0, matrix.shape[1]))
    z, weights, fitted = loc[:, 2], np.ones(len(loc)), np.zeros(len(loc))
    for _ in range(iterations):
        root = np.sqrt(weights)
        # lstsq (SVD, minimum norm): the ridged design repeats the quartic's low-order columns, which it tolerates
        coef, *_ = np.linalg.lstsq(
            np.vstack([matrix * root[:, None], penalty]), np.concatenate([z * root, np.zeros(len(penalty))]), rcond=None
        )
        new_fitted = matrix @ coef
        residual = z - new_fitted
        scale = max(1.4826 * float(np.median(np.abs(residual - np.median(residual)))), MIN_SCALE_MM)
        weights = np.minimum(1.0, HUBER_K * scale / np.maximum(np.abs(residual), 1e-12))
        done = np.max(np.abs(new_fitted - fitted)) < TOLERANCE_MM
        fitted = new_fitted
        if done:
            break
    return SkinModel(kind, coef, ridge_deg, knots)


def fit_ridged(loc: np.ndarray) -> SkinModel:
    """The ridged model in the direction that explains the ring best: a coarse then a fine search of the ridge
    direction by penalised least squares, then the robust fit."""
    if len(loc) < MIN_RIDGED_POINTS:
        raise InvalidInput(
            f"a ridged reference needs at least {MIN_RIDGED_POINTS} ring points on a "
            f"{THIN_CELL_MM:g} mm grid, got {len(loc)}; use a quartic or smaller one"
        )
    reach = float(np.abs(loc[:, :2]).max()) * math.sqrt(2) + 2 * RIDGE_KNOT_MM
    knots = np.arange(-reach, reach + RIDGE_KNOT_MM, RIDGE_KNOT_MM)

    def misfit(deg: float) -> float:
        model = fit("ridged", loc, deg, knots, iterations=1)
        return float(np.mean((loc[:, 2] - model.height(loc[:, 0], loc[:, 1])) ** 2))

    best = min(np.arange(0.0, 180.0, SEARCH_STEP_DEG), key=misfit)
    fine = np.arange(best - SEARCH_STEP_DEG / 2, best + SEARCH_STEP_DEG / 2 + 1e-9, REFINE_STEP_DEG)
    return fit("ridged", loc, float(min(fine, key=misfit)) % 180.0, knots)


def holdout_error_mm(loc: np.ndarray, centre_xy: np.ndarray, model: SkinModel) -> float:
    """Median absolute error predicting each angular sector of the ring (around the burn centre) from the rest,
    with the model's kind and, for ridges, its direction: how well it stands in for skin it has not seen. The
    ridge direction was chosen on the whole ring, held-out sector included (searching it again per sector costs
    8x): a slight advantage to the ridged model, which must beat the quartic clearly to be chosen."""
    angle = np.arctan2(loc[:, 1] - centre_xy[1], loc[:, 0] - centre_xy[0])
    sector = np.floor((angle + math.pi) / (2 * math.pi) * HOLDOUT_SECTORS).astype(np.int64) % HOLDOUT_SECTORS
    errors = []
    for k in range(HOLDOUT_SECTORS):
        held = sector == k
        if held.all() or not held.any():
            continue
        part = fit(model.kind, loc[~held], model.ridge_deg, model.knots, iterations=10)
        errors.append(np.abs(loc[held, 2] - part.height(loc[held, 0], loc[held, 1])))
    if not errors:
        raise InvalidInput("the ring has too few sectors to test the skin model on unseen skin")
    return float(np.median(np.concatenate(errors)))


def thin(loc: np.ndarray, cell_mm: float = THIN_CELL_MM, max_points: int = MAX_FIT_POINTS) -> np.ndarray:
    """One point per cell_mm square in (x, y), the cell widened until at most ~max_points remain."""
    while True:
        _, first = np.unique(np.floor(loc[:, :2] / cell_mm).astype(np.int64), axis=0, return_index=True)
        if len(first) <= max_points * 1.1:
            return loc[np.sort(first)]
        cell_mm *= math.sqrt(len(first) / max_points)


def _cubic_bspline(u: np.ndarray, knots: np.ndarray) -> np.ndarray:
    """Uniform cubic B-spline basis centred on the knots, one column per knot."""
    t = np.abs(np.asarray(u)[..., None] - knots) / (knots[1] - knots[0])
    return np.where(t < 1, 2 / 3 - t**2 + t**3 / 2, np.where(t < 2, (2 - t) ** 3 / 6, 0.0))


def _penalty(columns: int, n_knots: int, n_points: int) -> np.ndarray:
    """Rows penalising second differences of both profiles (level and along-ridge change)."""
    weight = math.sqrt(RIDGE_SMOOTHING * n_points / 1000.0)
    rows = []
    for start in (columns - 2 * n_knots, columns - n_knots):
        for i in range(n_knots - 2):
            row = np.zeros(columns)
            row[start + i : start + i + 3] = (weight, -2 * weight, weight)
            rows.append(row)
    return np.array(rows)
