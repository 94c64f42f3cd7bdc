"""The printable scale-marker sheet: strips of three ArUco markers of the configured dictionary and side, a 10 cm
check line and how to print and use it (GET /marker-sheet.pdf).

Every measurement in cm starts from this print, so it is drawn as vectors (one filled square per black cell of each
marker), never as a raster a printer could resample, and the check line lets a nurse confirm the print was not scaled.
Each strip carries its own three marker ids, so two strips in one scene are never confused.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import cv2
import numpy as np
from fpdf import FPDF

from processing.report.fonts import FAMILY, add_fonts
from schemas.errors import InvalidInput

CHECK_LINE_MM = 100.0
GAP_MM = 5.0
"""Between the markers of one strip, as the phantoms' strip (processing/phantom/marker_strip.py)."""
QUIET_MM = 6.0
"""White margin around the markers of a strip: the detector needs it to see a marker's black border."""
PAGE_MARGIN_MM = 14.0
STRIP_SPACING_MM = 8.0


class Paper(enum.StrEnum):
    a4 = "a4"
    letter = "letter"


PAPER_MM = {Paper.a4: (210.0, 297.0), Paper.letter: (215.9, 279.4)}


@dataclass(frozen=True)
class SheetLayout:
    dictionary: str
    side_mm: float
    strips: list[tuple[int, int, int]]
    """The marker ids of each strip, in print order."""


def aruco_dictionary(name: str) -> cv2.aruco.Dictionary:
    """The OpenCV ArUco dictionary of that name; InvalidInput naming it when there is none."""
    code = getattr(cv2.aruco, name, None)
    if not isinstance(code, int) or not name.startswith("DICT_"):
        raise InvalidInput(f"unknown ArUco dictionary {name!r}: use an OpenCV name such as DICT_4X4_50")
    return cv2.aruco.getPredefinedDictionary(code)


def marker_cells(dictionary: str, marker_id: int) -> np.ndarray:
    """The marker as a square of cells, its black border included: True where the print is black."""
    aruco = aruco_dictionary(dictionary)
    cells = aruco.markerSize + 2
    image = cv2.aruco.generateImageMarker(aruco, marker_id, cells, borderBits=1)
    return image < 128


def layout(dictionary: str, side_mm: float, paper: Paper) -> SheetLayout:
    """As many strips as fit the page beside the check line and the instructions, each with its own three ids."""
    if not 5.0 <= side_mm <= 60.0:
        raise InvalidInput(f"a marker side of {side_mm:g} mm cannot be printed usefully (5 to 60 mm)")
    count = aruco_dictionary(dictionary).bytesList.shape[0]
    width, height = PAPER_MM[paper]
    strip_w, strip_h = _strip_size(side_mm)
    columns = max(1, int((width - 2 * PAGE_MARGIN_MM + STRIP_SPACING_MM) // (strip_w + STRIP_SPACING_MM)))
    if strip_w > width - 2 * PAGE_MARGIN_MM:
        raise InvalidInput(f"a strip of three {side_mm:g} mm markers does not fit across {paper.value} paper")
    free = height - 2 * PAGE_MARGIN_MM - 100.0  # heading, check line and instructions
    rows = max(1, int((free + STRIP_SPACING_MM) // (strip_h + STRIP_SPACING_MM)))
    strips = min(columns * rows, count // 3)
    if strips < 1:
        raise InvalidInput(f"the dictionary {dictionary} has fewer than three markers")
    return SheetLayout(dictionary, side_mm, [(3 * k, 3 * k + 1, 3 * k + 2) for k in range(strips)])


def _strip_size(side_mm: float) -> tuple[float, float]:
    return 3 * side_mm + 2 * GAP_MM + 2 * QUIET_MM, side_mm + 2 * QUIET_MM


def render(dictionary: str, side_mm: float, paper: Paper = Paper.a4) -> bytes:
    """The sheet as a one-page PDF."""
    plan = layout(dictionary, side_mm, paper)
    width, height = PAPER_MM[paper]
    pdf = FPDF(unit="mm", format=(width, height))
    pdf.set_auto_page_break(False)
    pdf.set_margins(PAGE_MARGIN_MM, PAGE_MARGIN_MM)
    pdf.set_title("burnedge scale marker sheet")
    pdf.set_creator("burnedge")
    add_fonts(pdf)
    pdf.add_page()
    x0, y = PAGE_MARGIN_MM, PAGE_MARGIN_MM
    pdf.set_font(FAMILY, "B", 14)
    pdf.set_xy(x0, y)
    pdf.cell(text="burnedge scale marker sheet")
    pdf.set_font(FAMILY, "", 9)
    pdf.set_xy(x0, y + 7)
    pdf.cell(text=f"ArUco {dictionary}, each marker {side_mm:g} mm from outer black edge to outer black edge.")
    y = _check_line(pdf, x0, y + 16)
    y = _strips(pdf, plan, x0, y + 6, width)
    _instructions(pdf, x0, y + 4, width - 2 * PAGE_MARGIN_MM, side_mm)
    return bytes(pdf.output())


def _check_line(pdf: FPDF, x0: float, y: float) -> float:
    pdf.set_draw_color(0, 0, 0)
    pdf.set_line_width(0.3)
    pdf.line(x0, y + 4, x0 + CHECK_LINE_MM, y + 4)
    for tick in range(0, int(CHECK_LINE_MM) + 1, 10):
        length = 4.0 if tick in (0, int(CHECK_LINE_MM)) else 2.0
        pdf.line(x0 + tick, y + 4 - length, x0 + tick, y + 4)
    pdf.set_font(FAMILY, "B", 9)
    pdf.set_xy(x0, y + 6)
    pdf.cell(text="Check line: 10 cm. Measure it with a ruler before use.")
    return y + 12


def _strips(pdf: FPDF, plan: SheetLayout, x0: float, y0: float, page_w: float) -> float:
    strip_w, strip_h = _strip_size(plan.side_mm)
    columns = max(1, int((page_w - 2 * PAGE_MARGIN_MM + STRIP_SPACING_MM) // (strip_w + STRIP_SPACING_MM)))
    pdf.set_line_width(0.1)
    pdf.set_draw_color(150, 150, 150)
    bottom = y0
    for k, ids in enumerate(plan.strips):
        x = x0 + (k % columns) * (strip_w + STRIP_SPACING_MM)
        y = y0 + (k // columns) * (strip_h + STRIP_SPACING_MM)
        pdf.set_dash_pattern(dash=1.5, gap=1.5)
        pdf.rect(x, y, strip_w, strip_h)  # cut line
        pdf.set_dash_pattern()
        for n, marker_id in enumerate(ids):
            _marker(pdf, plan.dictionary, marker_id, x + QUIET_MM + n * (plan.side_mm + GAP_MM), y + QUIET_MM, plan)
        pdf.set_font(FAMILY, "", 6)
        pdf.set_text_color(90, 90, 90)
        pdf.set_xy(x + QUIET_MM, y + strip_h - 2.2)
        pdf.cell(text=f"strip {k + 1} · ids {ids[0]}-{ids[2]} · {plan.side_mm:g} mm")
        pdf.set_text_color(0, 0, 0)
        bottom = y + strip_h
    return bottom


def _marker(pdf: FPDF, dictionary: str, marker_id: int, x: float, y: float, plan: SheetLayout) -> None:
    cells = marker_cells(dictionary, marker_id)
    cell = plan.side_mm / cells.shape[0]
    pdf.set_fill_color(0, 0, 0)
    for row, col in zip(*np.nonzero(cells), strict=True):
        pdf.rect(x + col * cell, y + row * cell, cell, cell, style="F")


INSTRUCTIONS = (
    'Print at 100 % ("actual size"; not "fit to page"), on plain white paper, with a laser printer if there is one.',
    "Measure the check line. If it is not 10 cm (to within 1 mm), the print was scaled: print again. Every area and "
    "length burnedge reports in cm is only as right as this print.",
    "Cut out one strip along the dashed line. Keep it flat and clean: a creased or curled strip gives a wrong scale.",
    "Lay the strip flat on the skin or drape beside the burn, never on the burn itself, and keep all three squares "
    "in every photo.",
    "Use one strip per patient and discard it afterwards, as your clinic does with other paper at the bedside.",
)


def _instructions(pdf: FPDF, x0: float, y: float, width: float, side_mm: float) -> None:
    pdf.set_font(FAMILY, "B", 10)
    pdf.set_xy(x0, y)
    pdf.cell(text="How to print and use it")
    pdf.set_font(FAMILY, "", 8.5)
    pdf.set_xy(x0, y + 6)
    for n, line in enumerate(INSTRUCTIONS, start=1):
        pdf.set_x(x0)
        pdf.multi_cell(width, 4.2, f"{n}. {line}", align="L", new_x="LMARGIN", new_y="NEXT")
    pdf.set_x(x0)
    pdf.set_text_color(90, 90, 90)
    pdf.multi_cell(
        width,
        4.0,
        f"The gateway expects markers of {side_mm:g} mm ([quality] marker_side_mm and [reconstruction] "
        "marker_side_mm in its configuration); a sheet printed for another size gives a wrong scale.",
        align="L",
        new_x="LMARGIN",
        new_y="NEXT",
    )
    pdf.set_text_color(0, 0, 0)
