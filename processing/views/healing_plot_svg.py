"""The healing plots for the browser pages, as SVG: the measured visits against days since injury, the fitted area
line dashed, the projected closure with its 95 % range shaded, on the same axes the PDF report draws
(plot_scale.py) from the same figures (healing_series.py).

    healing_plot_svg(*, points, title, y_label, x_label="days since injury", unit="", digits=1, fit=None,
                     closure=None, marks=(), note="") -> str
    healing_plots_svg(track) -> [(title, svg), ...]   area, relief, volume

With fewer than two measured visits a plot draws its axes, the one visit if there is one, and says that a trend
needs two: no line, no fit, no projection.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from processing.report.figures import DIGITS
from processing.report.healing_series import CLOSURE_MARK, Closure, HealingSeries, healing_series
from processing.report.plot_scale import clip_fit, scales, tick_text
from processing.views.svg import element, num, svg_root, text, tooltip
from schemas.errors import InvalidInput
from schemas.longitudinal import TrackResult

__all__ = ["Closure", "healing_plot_svg", "healing_plots_svg"]

WIDTH, HEIGHT = 640.0, 300.0
LEFT, RIGHT, HEAD, FOOT = 62.0, WIDTH - 18.0, 44.0, HEIGHT - 46.0
X_TICKS = 8
INK, AXIS, GRID, SERIES, FIT, MARK, BAND = "#000000", "#5a5a5a", "#e1e1e1", "#194696", "#c85a14", "#6e6e6e", "#c85a14"
NO_VISITS = "no measured visits"
ONE_VISIT = "one visit so far: a trend needs two"
UNSCALED_NOTE = "visits without a scale (no marker in the photos) are not plotted: their sizes are not in cm or mm"


def _value(v: float, unit: str, digits: int) -> str:
    return f"{v:,.{digits}f} {unit}".strip()


def _range_text(closure: Closure) -> str:
    low = "?" if closure.earliest is None else f"{closure.earliest:.0f}"
    high = "open" if closure.latest is None else f"{closure.latest:.0f}"
    return f"95 % range {low} to {high}"


class _Frame:
    """Data to viewBox coordinates."""

    def __init__(self, x_end: float, y_end: float):
        self.x_end, self.y_end = x_end, y_end

    def x(self, v: float) -> float:
        return LEFT + (RIGHT - LEFT) * v / self.x_end

    def y(self, v: float) -> float:
        return FOOT - (FOOT - HEAD) * v / self.y_end


HALO = {"stroke": "#ffffff", "stroke-width": "4", "stroke-linejoin": "round", "paint-order": "stroke"}
"""A white edge under a label, so a line it crosses does not cut its letters."""


def _label(x: float, y: float, value: str, size: float = 11, **attrs) -> str:
    return element("text", {"x": num(x), "y": num(y), "font-size": num(size)} | attrs, text(value))


def _note(x: float, y: float, value: str, colour: str, anchor: str = "start", size: float = 11) -> str:
    """A label over the plot's lines, on a white edge."""
    return _label(x, y, value, size, fill=colour, **{"text-anchor": anchor} | HALO)


def _axes(f: _Frame, x_ticks, y_ticks, x_label: str, y_label: str) -> str:
    out = []
    y_step, x_step = y_ticks[1] - y_ticks[0], x_ticks[1] - x_ticks[0]
    for v in y_ticks:
        y = num(f.y(v))
        out.append(element("line", {"x1": num(LEFT), "y1": y, "x2": num(RIGHT), "y2": y, "stroke": GRID}))
        out.append(element("line", {"x1": num(LEFT - 4), "y1": y, "x2": num(LEFT), "y2": y, "stroke": AXIS}))
        out.append(_label(LEFT - 7, f.y(v) + 4, tick_text(v, y_step), **{"text-anchor": "end"}))
    for v in x_ticks:
        x = num(f.x(v))
        out.append(element("line", {"x1": x, "y1": num(FOOT), "x2": x, "y2": num(FOOT + 4), "stroke": AXIS}))
        out.append(_label(f.x(v), FOOT + 17, tick_text(v, x_step), **{"text-anchor": "middle"}))
    frame = f"M{num(LEFT)} {num(HEAD)} L{num(LEFT)} {num(FOOT)} L{num(RIGHT)} {num(FOOT)}"
    out.append(element("path", {"d": frame, "fill": "none", "stroke": AXIS, "stroke-width": "1.5"}))
    out.append(_label((LEFT + RIGHT) / 2, FOOT + 36, x_label, 12, **{"text-anchor": "middle"}))
    mid = (HEAD + FOOT) / 2
    turn = {"text-anchor": "middle", "transform": f"rotate(-90 18 {num(mid)})"}
    out.append(_label(18, mid + 4, y_label, 12, **turn))
    return element("g", {"class": "axes"}, *out)


def _vline(x: float, colour: str, dash: str) -> str:
    attrs = {"x1": num(x), "y1": num(HEAD), "x2": num(x), "y2": num(FOOT), "stroke": colour}
    return element("line", attrs | {"stroke-width": "1.2", "stroke-dasharray": dash})


def _mark_label(x: float, row: int, value: str, colour: str) -> str:
    """A label beside a mark's line, left of it near the right edge; rows keep near marks apart."""
    right = x + 4 + len(value) * 6.2 < RIGHT
    return _note(x + 4 if right else x - 4, HEAD + 12 + 13 * row, value, colour, "start" if right else "end")


def _closure(f: _Frame, closure: Closure, row: int) -> str:
    """The shaded 95 % range (to the plot's edge where it is open or runs past it), the day and its label."""
    low = 0.0 if closure.earliest is None else min(closure.earliest, f.x_end)
    high = f.x_end if closure.latest is None else min(closure.latest, f.x_end)
    out = []
    if high > low:
        band = {"x": num(f.x(low)), "y": num(HEAD), "width": num(f.x(high) - f.x(low)), "height": num(FOOT - HEAD)}
        out.append(element("rect", band | {"fill": BAND, "fill-opacity": "0.14", "class": "closure-range"}))
    words = f"{CLOSURE_MARK} day {closure.day:.0f} ({_range_text(closure)})"
    if closure.day <= f.x_end:
        out += [_vline(f.x(closure.day), FIT, "5 3"), _mark_label(f.x(closure.day), row, words, FIT)]
    else:
        beyond = f"{CLOSURE_MARK}: day {closure.day:.0f} ({_range_text(closure)}) →"
        out.append(_note(RIGHT - 2, HEAD + 12 + 13 * row, beyond, FIT, "end"))
    tip = f"{words}: an extrapolation of the fitted line, not a prediction of healing"
    return element("g", {"class": "closure"}, tooltip(tip), *out)


def _marks(f: _Frame, shown, beyond, first_row: int) -> list[str]:
    out = []
    for i, (v, label) in enumerate(sorted(shown)):
        out += [_vline(f.x(v), MARK, "3 3"), _mark_label(f.x(v), first_row + i % 2, label, MARK)]
    for i, (v, label) in enumerate(sorted(beyond)):
        value = f"{label} (day {v:.0f}) →"
        out.append(_note(RIGHT - 2, HEAD + 12 + 13 * (first_row + len(shown) + i), value, MARK, "end"))
    return [element("g", {"class": "marks"}, *out)] if out else []


def _points(f: _Frame, points, unit: str, digits: int) -> list[str]:
    ordered = sorted(points)
    out = []
    if len(ordered) >= 2:
        line = " ".join(f"{num(f.x(x))},{num(f.y(y))}" for x, y in ordered)
        out.append(element("polyline", {"points": line, "fill": "none", "stroke": SERIES, "stroke-width": "2"}))
    for x, y in ordered:
        dot = {"cx": num(f.x(x)), "cy": num(f.y(y)), "r": "4.5", "fill": SERIES, "class": "visit"}
        out.append(element("circle", dot, tooltip(f"day {x:g}: {_value(y, unit, digits)}")))
    return [element("g", {"class": "series"}, *out)] if out else []


def _message(count: int, note: str) -> list[str]:
    if count >= 2:
        return []
    lines = [NO_VISITS if count == 0 else ONE_VISIT] + ([note] if note else [])
    mid = (HEAD + FOOT) / 2
    out = [
        _note((LEFT + RIGHT) / 2, mid + 18 * i, line, MARK, "middle", 13 if i == 0 else 11)
        for i, line in enumerate(lines)
    ]
    return [element("g", {"class": "message"}, *out)]


def _key(fit_drawn: bool) -> str:
    """What the dot and the dashed line are, at the heading row's right."""
    y = 18.0
    parts = [element("circle", {"cx": num(RIGHT - 250), "cy": num(y), "r": "4.5", "fill": SERIES})]
    parts.append(_label(RIGHT - 240, y + 4, "measured visit"))
    if fit_drawn:
        dash = {"x1": num(RIGHT - 140), "y1": num(y), "x2": num(RIGHT - 116), "y2": num(y), "stroke": FIT}
        parts.append(element("line", dash | {"stroke-width": "1.8", "stroke-dasharray": "7 4"}))
        parts.append(_label(RIGHT - 110, y + 4, "fitted line"))
    return element("g", {"class": "key", "aria-hidden": "true"}, *parts)


def _description(title_text, points, unit, digits, fit, closure, note) -> str:
    ordered = sorted(points)
    parts = [f"{title_text}: {len(ordered)} measured visit{'' if len(ordered) == 1 else 's'}"]
    if ordered:
        parts.append("; ".join(f"day {x:g}: {_value(y, unit, digits)}" for x, y in ordered))
    if len(ordered) < 2:
        parts.append(ONE_VISIT if ordered else NO_VISITS)
    if fit is not None:
        parts.append(f"fitted line: {fit[1]:+.{digits + 1}f} {unit} per day".replace("  ", " "))
    if closure is not None:
        parts.append(
            f"{CLOSURE_MARK} day {closure.day:.0f} ({_range_text(closure)}): an extrapolation of the line, "
            "not a prediction of healing"
        )
    if note:
        parts.append(note)
    return ". ".join(p[:1].upper() + p[1:] for p in parts) + "."


def _check(points, fit, closure, marks) -> None:
    numbers = [v for p in points for v in p] + list(fit or ()) + [d for d, _ in marks]
    numbers += [v for v in (closure.day, closure.earliest, closure.latest) if v is not None] if closure else []
    if not all(math.isfinite(v) for v in numbers):
        raise InvalidInput(f"a healing plot needs finite numbers, got points {list(points)!r}, fit {fit!r}")
    if any(day < 0 for day, _ in points):
        raise InvalidInput(f"a healing plot's days start at 0, got {[day for day, _ in points]!r}")


def healing_plot_svg(
    *,
    points: Sequence[tuple[float, float]],
    title: str,
    y_label: str,
    x_label: str = "days since injury",
    unit: str = "",
    digits: int = 1,
    fit: tuple[float, float] | None = None,
    closure: Closure | None = None,
    marks: Sequence[tuple[float, str]] = (),
    note: str = "",
) -> str:
    """One plot as an `<svg>` element. `points`: (day, value); `unit`, `digits`: how a value is written in its
    tooltip; `fit` = (a, b) draws value = a + b·day dashed; `closure`: the projected day and its 95 % range;
    `marks`: reference days (day, label); `note`: a line under the message of a plot with under two visits."""
    _check(points, fit, closure, marks)
    trend = len(points) >= 2
    fit, closure = (fit, closure) if trend else (None, None)
    mark_list = ([(closure.day, CLOSURE_MARK)] if closure else []) + list(marks)
    axes = scales(points, fit, mark_list, X_TICKS)
    f = _Frame(axes.x_end, axes.y_end)
    body = [_axes(f, axes.x_ticks, axes.y_ticks, x_label, y_label)]
    shown = [m for m in axes.shown if m[1] != CLOSURE_MARK or closure is None]
    beyond = [m for m in axes.beyond if m[1] != CLOSURE_MARK or closure is None]
    if closure is not None:
        body.append(_closure(f, closure, 0))
    body += _marks(f, shown, beyond, 1 if closure is not None else 0)
    seg = clip_fit(fit, axes.x_end, axes.y_end) if fit is not None else None
    if seg is not None:
        line = {"x1": num(f.x(seg[0])), "y1": num(f.y(seg[1])), "x2": num(f.x(seg[2])), "y2": num(f.y(seg[3]))}
        style = {"stroke": FIT, "stroke-width": "1.8", "stroke-dasharray": "7 4", "class": "fit"}
        body.append(element("line", line | style, tooltip("fitted line (least squares)")))
    body += _points(f, points, unit, digits) + _message(len(points), note)
    desc = _description(title, points, unit, digits, fit, closure, note)
    head = [element("title", None, text(title)), element("desc", None, text(desc))]
    heading = _label(8, 22, title, 15, **{"font-weight": "bold", "fill": INK})
    if points:
        body.append(_key(seg is not None))
    return svg_root(WIDTH, HEIGHT, {"class": "healing-plot", "role": "img", "aria-label": title}, *head, heading, *body)


def _plot(series: HealingSeries, note: str) -> str:
    return healing_plot_svg(
        points=series.points,
        title=series.title,
        y_label=series.unit,
        unit=series.unit,
        digits=DIGITS[series.kind],
        fit=series.fit,
        closure=series.closure,
        marks=series.marks,
        note=note,
    )


def healing_plots_svg(track: TrackResult) -> list[tuple[str, str]]:
    """(title, svg) for the track's area, deepest-relief and volume plots, from the figures the PDF plots."""
    note = UNSCALED_NOTE if any(s.status == "unscaled" for s in track.sessions) else ""
    return [(series.title, _plot(series, note)) for series in healing_series(track)]
