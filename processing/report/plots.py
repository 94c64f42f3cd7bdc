"""Small vector line plots for the report (burn area over days): axes at round numbers from y = 0, the measured
points joined by a line, an optional fitted trend dashed, and dashed marks at given days."""

from __future__ import annotations

from collections.abc import Sequence

from fpdf import FPDF

from processing.report import fonts
from processing.report.plot_scale import MARK_REACH, MIN_DAYS, clip_fit, nice_step, scales, tick_text, ticks

INK = (0, 0, 0)
AXIS = (90, 90, 90)
GRID = (225, 225, 225)
SERIES = (25, 70, 150)
FIT = (200, 90, 20)
MARK = (120, 120, 120)
LABEL_PT = 6.5
_ticks, _number, _clip_fit = ticks, tick_text, clip_fit  # the names the drawing tests have used
__all__ = ["MARK_REACH", "MIN_DAYS", "line_plot", "nice_step"]


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
    axes = scales(points, fit, marks, int(min(max(w / 15, 4), 10)))
    x_end, x_ticks, y_end, y_ticks = axes.x_end, axes.x_ticks, axes.y_end, axes.y_ticks
    shown, beyond = axes.shown, axes.beyond

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
        if fit is not None and (seg := clip_fit(fit, x_end, y_end)) is not None:
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
        pdf.cell(9.6, 3, tick_text(v, y_step), align="R")
    for v in x_ticks:
        pdf.set_draw_color(*AXIS)
        pdf.line(sx(v), foot, sx(v), foot + 1.0)
        pdf.set_xy(sx(v) - 5, foot + 1.2)
        pdf.cell(10, 3, tick_text(v, x_step), align="C")
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
