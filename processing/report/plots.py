"""Small vector line plots for the report (burn area over days): axes at round numbers from y = 0, the measured
points joined by a line, an optional fitted trend dashed, and dashed marks at given days."""

from __future__ import annotations

import math
from collections.abc import Sequence

from fpdf import FPDF

from processing.report import fonts

INK = (0, 0, 0)
AXIS = (90, 90, 90)
GRID = (225, 225, 225)
SERIES = (25, 70, 150)
FIT = (200, 90, 20)
MARK = (120, 120, 120)
LABEL_PT = 6.5
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


def _ticks(top: float, ticks: int = 5) -> tuple[float, list[float]]:
    """Axis end (a round number >= top) and the ticks from 0 to it."""
    step = nice_step(top, ticks)
    end = math.ceil(top / step - 1e-9) * step
    return end, [i * step for i in range(round(end / step) + 1)]


def _number(value: float, step: float) -> str:
    digits = max(0, -math.floor(math.log10(step))) if step < 1 else 0
    return f"{value:.{digits}f}"


def _clip_fit(fit: tuple[float, float], x_end: float, y_end: float) -> tuple[float, float, float, float] | None:
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


def line_plot(
    pdf: FPDF,
    x: float,
    y: float,
    w: float,
    h: float,
    *,
    points: list[tuple[float, float]],
    title: str,
    y_label: str,
    x_label: str = "days since injury",
    fit: tuple[float, float] | None = None,
    marks: Sequence[tuple[float, str]] = (),
) -> None:
    """Draw the plot in the box (x, y, w, h), mm. `fit` = (a, b) draws y = a + b·x dashed; `marks` are (x, label)."""
    last = max((px for px, _ in points), default=0.0)
    reach = max(MARK_REACH * last, 30.0)
    shown = [m for m in marks if 0 <= m[0] <= reach]
    beyond = [m for m in marks if m[0] > reach]
    x_end, x_ticks = _ticks(max([last, MIN_DAYS] + [m[0] for m in shown]), ticks=int(min(max(w / 15, 4), 10)))
    top = max([py for _, py in points] + [1e-9])
    if fit is not None:
        top = max(top, min(max(fit[0], fit[0] + fit[1] * x_end), 1.5 * top if points else math.inf))
    y_end, y_ticks = _ticks(top * 1.08 if top > 1e-9 else 1.0)

    left, right, head, foot = x + 11.0, x + w - 2.0, y + 5.5, y + h - 8.5
    sx = lambda v: left + (right - left) * v / x_end  # noqa: E731
    sy = lambda v: foot - (foot - head) * v / y_end  # noqa: E731
    with pdf.local_context():
        pdf.set_text_color(*INK)
        pdf.set_font(fonts.FAMILY, "B", 8)
        pdf.set_xy(x, y)
        pdf.cell(w, 4, title)
        _axes(pdf, (left, right, head, foot), x_ticks, y_ticks, sx, sy)
        pdf.set_font(fonts.FAMILY, "", LABEL_PT)
        pdf.set_xy(left, foot + 4.2)
        pdf.cell(right - left, 3.5, x_label, align="C")
        cx, cy = x + 2.2, (head + foot) / 2
        with pdf.rotation(90, cx, cy):
            pdf.text(cx - pdf.get_string_width(y_label) / 2, cy + 0.8, y_label)
        if fit is not None and (seg := _clip_fit(fit, x_end, y_end)) is not None:
            pdf.set_draw_color(*FIT)
            pdf.set_line_width(0.35)
            pdf.set_dash_pattern(dash=1.4, gap=0.9)
            pdf.line(sx(seg[0]), sy(seg[1]), sx(seg[2]), sy(seg[3]))
        _marks(pdf, shown, beyond, sx, head, foot, right)
        pdf.set_dash_pattern()
        _series(pdf, points, sx, sy, (left, right, head, foot))


def _axes(pdf: FPDF, box, x_ticks, y_ticks, sx, sy) -> None:
    left, right, head, foot = box
    pdf.set_font(fonts.FAMILY, "", LABEL_PT)
    pdf.set_line_width(0.12)
    x_step, y_step = x_ticks[1] - x_ticks[0], y_ticks[1] - y_ticks[0]
    for v in y_ticks:
        pdf.set_draw_color(*GRID)
        pdf.line(left, sy(v), right, sy(v))
        pdf.set_draw_color(*AXIS)
        pdf.line(left - 1.0, sy(v), left, sy(v))
        pdf.set_xy(left - 11.0, sy(v) - 1.5)
        pdf.cell(9.6, 3, _number(v, y_step), align="R")
    for v in x_ticks:
        pdf.set_draw_color(*AXIS)
        pdf.line(sx(v), foot, sx(v), foot + 1.0)
        pdf.set_xy(sx(v) - 5, foot + 1.2)
        pdf.cell(10, 3, _number(v, x_step), align="C")
    pdf.set_draw_color(*AXIS)
    pdf.set_line_width(0.25)
    pdf.line(left, head, left, foot)
    pdf.line(left, foot, right, foot)


def _marks(pdf: FPDF, shown, beyond, sx, head, foot, right) -> None:
    pdf.set_font(fonts.FAMILY, "", LABEL_PT - 0.5)
    pdf.set_text_color(*MARK)
    pdf.set_fill_color(255, 255, 255)
    pdf.set_draw_color(*MARK)
    pdf.set_line_width(0.2)
    pdf.set_dash_pattern(dash=0.8, gap=0.8)
    for i, (v, label) in enumerate(sorted(shown)):
        pdf.line(sx(v), head, sx(v), foot)
        width = pdf.get_string_width(label) + 1
        # Labels alternate rows so two near marks stay readable; they sit left of the line near the right edge.
        lx = sx(v) + 0.6 if sx(v) + width < right else sx(v) - width - 0.6
        pdf.set_xy(lx, head + (i % 2) * 3.0)
        pdf.cell(width, 3, label, fill=True)
    for i, (v, label) in enumerate(sorted(beyond)):
        text = f"{label} (day {v:.0f}) →"
        width = pdf.get_string_width(text) + 1
        pdf.set_xy(right - width, head + (len(shown) + i) % 4 * 3.0)
        pdf.cell(width, 3, text, align="R", fill=True)
    pdf.set_text_color(*INK)


def _series(pdf: FPDF, points, sx, sy, box) -> None:
    left, right, head, foot = box
    if not points:
        pdf.set_font(fonts.FAMILY, "", 7.5)
        pdf.set_text_color(*MARK)
        pdf.set_xy(left, (head + foot) / 2 - 2)
        pdf.cell(right - left, 4, "no measured visits", align="C")
        return
    ordered = sorted(points)
    pdf.set_draw_color(*SERIES)
    pdf.set_fill_color(*SERIES)
    pdf.set_line_width(0.4)
    for (x0, y0), (x1, y1) in zip(ordered, ordered[1:], strict=False):
        pdf.line(sx(x0), sy(y0), sx(x1), sy(y1))
    for px, py in ordered:
        pdf.circle(sx(px), sy(py), 0.85, style="F")
