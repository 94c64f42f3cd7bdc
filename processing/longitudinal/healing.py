"""Healing figures from a burn's areas over the visits: change against the baseline, healing rate, projected
closure, and review prompts from published rules. Pure functions of numbers.

Sign conventions: a *change* is later minus baseline (negative = smaller); the *reduction* and the *healing
rate* are positive when the burn shrinks, as in the wound-care literature.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import stats

from schemas.config import TrackingConfig
from schemas.longitudinal import StallFlag

KANTOR_2000 = (
    "Kantor J, Margolis DJ. A multicentre study of percentage change in venous leg ulcer area as a prognostic index "
    "of healing at 24 weeks. Br J Dermatol 2000;142(5):960-964 (venous leg ulcers, not burns: the percentage change "
    "in area over the first 4 weeks predicted healing by 24 weeks)"
)
DEITCH_1983 = (
    "Deitch EA, et al. Hypertrophic burn scars: analysis of variables. J Trauma 1983;23(10):895-898 (100 patients: "
    "burns healed in 14-21 days became hypertrophic at one third of sites, those healed after 21 days at 78 %)"
)


@dataclass(frozen=True)
class Figures:
    """One visit's measurements (None where the analysis gave none)."""

    area_cm2: float
    relief_max_mm: float | None = None
    volume_cm3: float | None = None


@dataclass(frozen=True)
class Change:
    area_change_cm2: float
    area_change_percent: float | None
    """None when the baseline area is 0."""
    percent_area_reduction: float | None
    relief_change_mm: float | None
    volume_change_cm3: float | None


def change(baseline: Figures, current: Figures) -> Change:
    """Current visit against the baseline: A_t - A_0, 100 (A_t - A_0) / A_0, its opposite (reduction), and the
    changes of the deepest relief and of the volume when both visits have them."""
    delta = current.area_cm2 - baseline.area_cm2
    percent = 100.0 * delta / baseline.area_cm2 if baseline.area_cm2 > 0 else None

    def diff(a: float | None, b: float | None) -> float | None:
        return None if a is None or b is None else b - a

    return Change(
        area_change_cm2=delta,
        area_change_percent=percent,
        percent_area_reduction=None if percent is None else -percent,
        relief_change_mm=diff(baseline.relief_max_mm, current.relief_max_mm),
        volume_change_cm3=diff(baseline.volume_cm3, current.volume_cm3),
    )


@dataclass(frozen=True)
class Rate:
    """The least-squares line area = a + b day over the measured visits; rate = -b (positive = shrinking)."""

    n: int
    rate_cm2_per_day: float | None
    se_cm2_per_day: float | None
    """Standard error of the slope; None with fewer than 3 visits (no residual left to estimate it)."""
    mean_day: float
    mean_area_cm2: float
    sxx: float
    """Sum of squared deviations of the days from their mean."""
    residual_sd_cm2: float | None
    reason: str = ""
    """Why no rate could be fitted."""


def healing_rate(days: list[float], areas: list[float]) -> Rate:
    """Least-squares line through every measured visit (not only the first and the last)."""
    x, y = np.asarray(days, float), np.asarray(areas, float)
    n = len(x)
    mean_day, mean_area = (float(x.mean()), float(y.mean())) if n else (math.nan, math.nan)
    sxx = float(np.sum((x - mean_day) ** 2)) if n else 0.0
    if n < 2 or sxx == 0:
        return Rate(
            n,
            None,
            None,
            mean_day,
            mean_area,
            sxx,
            None,
            reason="a healing rate needs measured visits on at least two different days",
        )
    slope = float(np.sum((x - mean_day) * (y - mean_area)) / sxx)
    if n < 3:
        return Rate(n, -slope, None, mean_day, mean_area, sxx, None)
    residuals = y - (mean_area + slope * (x - mean_day))
    sd = float(np.sqrt(np.sum(residuals**2) / (n - 2)))
    return Rate(n, -slope, sd / math.sqrt(sxx), mean_day, mean_area, sxx, sd)


@dataclass(frozen=True)
class Projection:
    day: float | None
    """Day the fitted line reaches zero area."""
    earliest: float | None
    latest: float | None
    """None: the data cannot exclude that the burn stops shrinking."""
    note: str = ""


def projected_closure(rate: Rate, level: float = 0.95) -> Projection:
    """Where the fitted line reaches zero, with Fieller's interval: the days x at which a zero area is not
    contradicted by the line's uncertainty, |mean + slope (x - mean_day)| <= t s sqrt(1/n + (x - mean_day)^2 / Sxx),
    t the Student quantile with n - 2 degrees of freedom. It accounts for the level and the slope of the line; a
    straight line is an assumption (healing often slows as the wound closes), so the projection is an
    extrapolation to check at the next visit."""
    if rate.rate_cm2_per_day is None:
        return Projection(None, None, None, f"no projection: {rate.reason}")
    if rate.n < 3:
        return Projection(
            None,
            None,
            None,
            "no projection: it needs at least three measured visits (two visits fix a "
            "line but say nothing about its uncertainty)",
        )
    if rate.rate_cm2_per_day <= 0:
        return Projection(
            None,
            None,
            None,
            f"no projection: the area is not shrinking (fitted rate {rate.rate_cm2_per_day:+.3f} cm2/day)",
        )
    slope, mean = -rate.rate_cm2_per_day, rate.mean_area_cm2
    day = rate.mean_day - mean / slope
    t = float(stats.t.ppf(0.5 + level / 2, rate.n - 2))
    spread = (t * (rate.residual_sd_cm2 or 0.0)) ** 2
    a, b, c = slope**2 - spread / rate.sxx, 2 * mean * slope, mean**2 - spread / rate.n
    disc = b * b - 4 * a * c
    if a > 0:  # the slope is certain: a bounded interval (it holds the estimate, so disc >= 0 up to rounding)
        root = math.sqrt(max(disc, 0.0))
        low, high = sorted(((-b - root) / (2 * a), (-b + root) / (2 * a)))
        return Projection(day, rate.mean_day + low, rate.mean_day + high)
    note = (
        "the shrinking is not certain at the 95 % level (the slope's interval includes zero): the latest "
        "closure day is open"
    )
    if disc <= 0 or a == 0:
        return Projection(day, None, None, note)
    low, high = sorted(((-b - math.sqrt(disc)) / (2 * a), (-b + math.sqrt(disc)) / (2 * a)))
    if day - rate.mean_day >= high:  # the estimate lies on the half-line beyond the larger root
        return Projection(day, rate.mean_day + high, None, note)
    return Projection(day, None, rate.mean_day + low, note)


def _fmt(day: float) -> str:
    return f"{day:g}"


def shrink_flag(conf: TrackingConfig, days: list[float], areas: list[float]) -> StallFlag:
    """Kantor & Margolis: less than 40 % area reduction 4 weeks after the first measured visit. Judged on the
    latest measured visit at or after 4 weeks."""
    rule = (
        f"less than {conf.stall_reduction_percent:g} % area reduction {_fmt(conf.stall_after_days)} days after "
        "the first measured visit"
    )
    late = [i for i, d in enumerate(days) if d - days[0] >= conf.stall_after_days]
    if not late:
        span = days[-1] - days[0] if days else 0.0
        return StallFlag(
            rule=rule,
            citation=KANTOR_2000,
            evaluable=False,
            triggered=False,
            detail=f"not yet evaluable: the last measured visit is {_fmt(span)} days after the first "
            f"({_fmt(conf.stall_after_days)} needed)",
        )
    i = late[-1]
    reduction = 100.0 * (areas[0] - areas[i]) / areas[0] if areas[0] > 0 else 0.0
    triggered = reduction < conf.stall_reduction_percent
    detail = (
        f"day {_fmt(days[i])}: area reduced by {reduction:.0f} % since day {_fmt(days[0])} "
        f"({areas[0]:.2f} -> {areas[i]:.2f} cm2)"
    )
    if triggered:
        detail += (
            "; in chronic wounds this predicted poor healing: consider a clinical review of the wound and of "
            "its treatment"
        )
    return StallFlag(rule=rule, citation=KANTOR_2000, evaluable=True, triggered=triggered, detail=detail)


def day21_flag(conf: TrackingConfig, days: list[float], areas: list[float]) -> StallFlag:
    """Deitch et al.: a burn not healed by day 21 after the injury. Judged on the latest measured visit."""
    deadline = _fmt(conf.healing_deadline_day)
    rule = f"burn not healed by day {deadline} after the injury (days as given: days since the injury)"
    if not days or days[-1] < conf.healing_deadline_day:
        last = f"day {_fmt(days[-1])}" if days else "none"
        return StallFlag(
            rule=rule,
            citation=DEITCH_1983,
            evaluable=False,
            triggered=False,
            detail=f"not yet evaluable: the last measured visit is {last}",
        )
    open_area = areas[-1]
    triggered = open_area >= conf.healed_area_cm2
    detail = f"day {_fmt(days[-1])}: {open_area:.2f} cm2 still open"
    if triggered:
        detail += (
            "; the risk of hypertrophic scarring rises steeply after 21 days: consider review by the burn team "
            "for surgical management and scar prevention"
        )
    else:
        detail += f" (under {conf.healed_area_cm2:g} cm2: counted as healed; confirm on examination)"
    return StallFlag(rule=rule, citation=DEITCH_1983, evaluable=True, triggered=triggered, detail=detail)


def projected_day21_flag(conf: TrackingConfig, days: list[float], projection: Projection) -> StallFlag:
    """The same rule looked at ahead of time: the fitted line reaches zero after day 21."""
    deadline = _fmt(conf.healing_deadline_day)
    rule = f"projected closure after day {deadline} after the injury (the fitted line of area against day)"
    if days and days[-1] >= conf.healing_deadline_day:
        return StallFlag(
            rule=rule,
            citation=DEITCH_1983,
            evaluable=False,
            triggered=False,
            detail=f"not needed: a visit on or after day {deadline} was measured (see the rule above)",
        )
    if projection.day is None:
        return StallFlag(
            rule=rule,
            citation=DEITCH_1983,
            evaluable=False,
            triggered=False,
            detail=f"not yet evaluable: {projection.note.removeprefix('no projection: ')}",
        )
    low = "?" if projection.earliest is None else f"{projection.earliest:.0f}"
    high = "open" if projection.latest is None else f"{projection.latest:.0f}"
    triggered = projection.day > conf.healing_deadline_day
    detail = f"projected closure on day {projection.day:.0f} (95 % range {low} to {high})"
    if triggered:
        detail += (
            f": at this pace the burn would not be healed by day {deadline}; consider early review by the burn "
            "team (an extrapolation: re-measure at the next visit)"
        )
    return StallFlag(rule=rule, citation=DEITCH_1983, evaluable=True, triggered=triggered, detail=detail)


def stall_flags(conf: TrackingConfig, days: list[float], areas: list[float], projection: Projection) -> list[StallFlag]:
    """Every review prompt, evaluable or not, for the measured visits (days ascending, areas in cm2)."""
    return [shrink_flag(conf, days, areas), day21_flag(conf, days, areas), projected_day21_flag(conf, days, projection)]
