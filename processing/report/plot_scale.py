"""The healing plots' scales, shared by the PDF report and the browser pages: round ticks from 0, an x axis of at
least a week that takes in the marks near the visits, and the fitted line clipped to the plot. Pure: no drawing."""

from __future__ import annotations

import math
from collections.abc import Sequence

import msgspec

MIN_DAYS = 7.0
"""The x axis spans at least a week, so a first visit on day 1 is not drawn at the far right."""
MARK_REACH = 3.0
"""A mark beyond this many times the last measured day (or day 30) is named at the right edge, not scaled in:
a far projected closure must not squash the measured visits into the left edge."""


def nice_step(span: float, ticks: int = 5) -> float:
    """A round tick step (1, 2 or 5 times a power of ten) giving about `ticks` intervals over `span`."""
    raw = max(span, 1e-9) / ticks
    power = 10 ** math.floor(math.log10(raw))
    return next(m * power for m in (1, 2, 5, 10) if m * power >= raw)


def ticks(top: float, count: int = 5) -> tuple[float, list[float]]:
    """Axis end (a round number >= top) and the ticks from 0 to it."""
    step = nice_step(top, count)
    end = math.ceil(top / step - 1e-9) * step
    return end, [i * step for i in range(round(end / step) + 1)]


def tick_text(value: float, step: float) -> str:
    """A tick's number with as many decimals as its step needs."""
    digits = max(0, -math.floor(math.log10(step))) if step < 1 else 0
    return f"{value:.{digits}f}"


def clip_fit(fit: tuple[float, float], x_end: float, y_end: float) -> tuple[float, float, float, float] | None:
    """The part of y = a + b x inside 0 <= x <= x_end, 0 <= y <= y_end, as (x0, y0, x1, y1); None when outside."""
    a, b = fit
    lo, hi = 0.0, x_end
    if b == 0:
        if not 0 <= a <= y_end:
            return None
    else:
        t0, t1 = sorted(((0 - a) / b, (y_end - a) / b))
        lo, hi = max(lo, t0), min(hi, t1)
    if hi <= lo:
        return None
    return lo, a + b * lo, hi, a + b * hi


class Scales(msgspec.Struct, frozen=True):
    """A plot's axes: where each ends, its ticks, and the marks drawn in it or only named at its right edge."""

    x_end: float
    x_ticks: list[float]
    y_end: float
    y_ticks: list[float]
    shown: list[tuple[float, str]]
    beyond: list[tuple[float, str]]


def scales(
    points: Sequence[tuple[float, float]],
    fit: tuple[float, float] | None,
    marks: Sequence[tuple[float, str]],
    x_tick_count: int,
) -> Scales:
    """Axes from 0 that hold the points, the marks within reach and the fit's start (at most 1.5 x the highest
    point), with about `x_tick_count` intervals on x and 5 on y."""
    last = max((px for px, _ in points), default=0.0)
    reach = max(MARK_REACH * last, 30.0)
    shown = [m for m in marks if 0 <= m[0] <= reach]
    beyond = [m for m in marks if m[0] > reach]
    x_end, x_ticks = ticks(max([last, MIN_DAYS] + [m[0] for m in shown]), x_tick_count)
    top = max([py for _, py in points] + [1e-9])
    if fit is not None:
        top = max(top, min(max(fit[0], fit[0] + fit[1] * x_end), 1.5 * top if points else math.inf))
    y_end, y_ticks = ticks(top * 1.08 if top > 1e-9 else 1.0)
    return Scales(x_end, x_ticks, y_end, y_ticks, shown, beyond)
