"""The burn chart as a Lund-Browder body diagram on the PDF: front and back views drawn as vector polygons, each
region its own closed polygon (body_geometry.py), filled by the clinician's depth category.

A region charted at several depths is passed at its deepest (the caller's choice, stated in the report's text):
one region, one fill. Which side of each view is the patient's right: see body_geometry.py.
"""

from __future__ import annotations

import math

from fpdf import FPDF

from processing.report import fonts
from processing.report.body_geometry import (
    BACK,
    DEPTH_FILL,
    DEPTH_HATCH,
    DEPTH_LEGEND,
    FRONT,
    OUTLINE,
    REGION_POLYGONS,
    REGION_VIEW,
    UNCHARTED,
    inner_point,
    inside,
    region_point,
    view_boxes,
)
from schemas.burn_chart import BurnDepth, LundBrowderRegion

__all__ = ["BACK", "DEPTH_FILL", "DEPTH_HATCH", "DEPTH_LEGEND", "FRONT", "REGION_POLYGONS", "REGION_VIEW"]
__all__ += ["draw_body_chart", "region_point"]
HATCH_STEP_MM = 1.3
_inner_point, _inside = inner_point, inside  # the names the drawing tests have used


def _hatch(pdf: FPDF, poly_mm, angle_deg: float) -> None:
    """Parallel lines at `angle_deg` clipped to the polygon (even-odd crossings), HATCH_STEP_MM apart."""
    ux, uy = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))
    nx, ny = -uy, ux
    offsets = [px * nx + py * ny for px, py in poly_mm]
    edges = list(zip(poly_mm, poly_mm[1:] + poly_mm[:1], strict=True))
    c = math.floor(min(offsets) / HATCH_STEP_MM) * HATCH_STEP_MM + HATCH_STEP_MM / 2
    while c < max(offsets):
        ts = []
        for (x1, y1), (x2, y2) in edges:
            d1, d2 = x1 * nx + y1 * ny - c, x2 * nx + y2 * ny - c
            if (d1 > 0) != (d2 > 0):
                s = d1 / (d1 - d2)
                ts.append((x1 + s * (x2 - x1)) * ux + (y1 + s * (y2 - y1)) * uy)
        ts.sort()
        for t0, t1 in zip(ts[::2], ts[1::2], strict=False):
            pdf.line(c * nx + t0 * ux, c * ny + t0 * uy, c * nx + t1 * ux, c * ny + t1 * uy)
        c += HATCH_STEP_MM


def _region(pdf: FPDF, poly_mm, depth: BurnDepth | None) -> None:
    pdf.set_fill_color(*(DEPTH_FILL[depth] if depth else UNCHARTED))
    pdf.set_draw_color(*OUTLINE)
    pdf.set_line_width(0.18)
    pdf.polygon(poly_mm, style="DF")
    if depth in DEPTH_HATCH:
        pdf.set_draw_color(255, 255, 255)
        pdf.set_line_width(0.22)
        for angle in DEPTH_HATCH[depth]:
            _hatch(pdf, poly_mm, angle)


def _swatch(pdf: FPDF, x: float, y: float, depth: BurnDepth | None, label: str) -> None:
    box = [(x, y), (x + 5, y), (x + 5, y + 3.2), (x, y + 3.2)]
    _region(pdf, box, depth)
    pdf.set_xy(x + 6, y - 0.4)
    pdf.cell(0, 4, label)


def draw_body_chart(
    pdf: FPDF, x: float, y: float, w: float, h: float, shading: dict[LundBrowderRegion, BurnDepth]
) -> None:
    """Draw the chart in the box (x, y, w, h), mm. `shading`: each charted region at its deepest depth."""
    boxes = view_boxes(x, y, w, h)
    with pdf.local_context():
        for region, poly in REGION_POLYGONS.items():
            bx, by, bw, bh = boxes[REGION_VIEW[region]]
            _region(pdf, [(bx + px * bw, by + py * bh) for px, py in poly], shading.get(region))
        pdf.set_text_color(0, 0, 0)
        for view, (bx, by, bw, _bh) in boxes.items():
            pdf.set_font(fonts.FAMILY, "B", 9)
            pdf.set_xy(bx, by - 5)
            pdf.cell(bw, 4, "Front" if view == FRONT else "Back", align="C")
            # The patient's sides on the title row, at the view's edges: the reader's left is the patient's right
            # in the front view only.
            left, right = ("Right", "Left") if view == FRONT else ("Left", "Right")
            pdf.set_font(fonts.FAMILY, "", 7)
            pdf.set_xy(bx, by - 4.6)
            pdf.cell(bw, 3.5, left, align="L")
            pdf.set_xy(bx, by - 4.6)
            pdf.cell(bw, 3.5, right, align="R")
        pdf.set_font(fonts.FAMILY, "", 7)
        top = boxes[FRONT][1] + boxes[FRONT][3] + 2.5
        entries = [(d, DEPTH_LEGEND[d]) for d in BurnDepth]
        for i, (depth, label) in enumerate(entries):
            _swatch(pdf, x + 2 + (i // 2) * w / 2, top + (i % 2) * 4.4, depth, label)
