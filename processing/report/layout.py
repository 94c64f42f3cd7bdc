"""The report's page: A4 portrait, the footer on every page, and the few text blocks every section uses."""

from __future__ import annotations

from fpdf import FPDF
from fpdf.enums import XPos, YPos

from processing.report import fonts

FOOTER_NOTICE = "Decision support only — confirmed by a clinician"
MARGIN = 14.0
TEXT = 9.0
SMALL = 7.5
GREY = (95, 95, 95)
RULE = (190, 190, 190)
URGENT = (170, 20, 20)
NOT_RECORDED = "not recorded"


class ReportPDF(FPDF):
    def __init__(self, report_id: str, versions_sha256: str):
        super().__init__(orientation="portrait", unit="mm", format="A4")
        self.report_id = report_id
        self.versions_sha256 = versions_sha256
        fonts.add_fonts(self)
        self.set_margins(MARGIN, MARGIN, MARGIN)
        self.set_auto_page_break(auto=True, margin=20)
        self.alias_nb_pages()
        self.set_font(fonts.FAMILY, size=TEXT)

    def footer(self) -> None:
        self.set_y(-15)
        self.set_draw_color(*RULE)
        self.line(MARGIN, self.get_y(), self.w - MARGIN, self.get_y())
        self.set_font(fonts.FAMILY, "B", SMALL)
        self.set_text_color(0, 0, 0)
        self.cell(self.epw * 0.7, 4, FOOTER_NOTICE)
        self.cell(0, 4, f"page {self.page_no()} of {{nb}}", align="R", new_x=XPos.LMARGIN, new_y=YPos.NEXT)
        self.set_font(fonts.FAMILY, "", SMALL - 1.5)
        self.set_text_color(*GREY)
        self.cell(0, 3.5, f"Report {self.report_id} · record versions SHA-256 {self.versions_sha256}")
        self.set_text_color(0, 0, 0)

    # text blocks ---------------------------------------------------------------------------------------------
    def doc_title(self, text: str) -> None:
        self.set_font(fonts.FAMILY, "B", 15)
        self.cell(0, 8, text, new_x=XPos.LMARGIN, new_y=YPos.NEXT)
        self.set_font(fonts.FAMILY, "", TEXT)

    def heading(self, text: str, *, new_page_if_below: float = 40) -> None:
        if self.get_y() > self.h - 20 - new_page_if_below:
            self.add_page()
        self.ln(2)
        self.set_font(fonts.FAMILY, "B", 11.5)
        self.cell(0, 6.5, text, new_x=XPos.LMARGIN, new_y=YPos.NEXT)
        self.set_draw_color(*RULE)
        self.line(MARGIN, self.get_y(), self.w - MARGIN, self.get_y())
        self.ln(1.5)
        self.set_font(fonts.FAMILY, "", TEXT)

    def subheading(self, text: str) -> None:
        self.ln(1)
        self.set_font(fonts.FAMILY, "B", TEXT + 0.5)
        self.multi_cell(0, 5, text, align="L", new_x=XPos.LMARGIN, new_y=YPos.NEXT)
        self.set_font(fonts.FAMILY, "", TEXT)

    def para(self, text: str, *, size: float = TEXT, bold: bool = False, colour=(0, 0, 0), indent: float = 0) -> None:
        self.set_font(fonts.FAMILY, "B" if bold else "", size)
        self.set_text_color(*colour)
        self.set_x(MARGIN + indent)
        self.multi_cell(self.epw - indent, size * 0.5, text, align="L", new_x=XPos.LMARGIN, new_y=YPos.NEXT)
        self.set_text_color(0, 0, 0)
        self.set_font(fonts.FAMILY, "", TEXT)

    def bullets(self, lines: list[str], *, size: float = TEXT, colour=(0, 0, 0)) -> None:
        for line in lines:
            self.para(f"• {line}", size=size, colour=colour, indent=3)

    def facts(self, rows: list[tuple[str, str]], *, label_width: float = 42) -> None:
        """Label and value rows; the value wraps beside its label."""
        for label, value in rows:
            if self.get_y() > self.h - 28:
                self.add_page()
            y = self.get_y()
            self.set_font(fonts.FAMILY, "B", TEXT)
            self.set_text_color(*GREY)
            self.multi_cell(label_width - 2, 4.6, label, align="L", new_x=XPos.LMARGIN, new_y=YPos.NEXT)
            below_label = self.get_y()
            self.set_text_color(0, 0, 0)
            self.set_font(fonts.FAMILY, "", TEXT)
            self.set_xy(MARGIN + label_width, y)
            value = value or NOT_RECORDED
            self.multi_cell(self.epw - label_width, 4.6, value, align="L", new_x=XPos.LMARGIN, new_y=YPos.NEXT)
            self.set_y(max(self.get_y(), below_label))

    def table(self, header: list[str], rows: list[list[str]], widths: list[float]) -> None:
        self.set_font(fonts.FAMILY, "B", SMALL + 0.5)
        self.set_fill_color(235, 235, 235)
        for text, width in zip(header, widths, strict=True):
            self.cell(width, 5, text, border=0, fill=True)
        self.ln(5)
        self.set_font(fonts.FAMILY, "", SMALL + 0.5)
        for row in rows:
            if self.get_y() > self.h - 26:
                self.add_page()
            for text, width in zip(row, widths, strict=True):
                self.cell(width, 4.6, text)
            self.ln(4.6)
        self.set_font(fonts.FAMILY, "", TEXT)
