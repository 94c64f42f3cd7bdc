"""The report's typeface: DejaVu Sans, vendored beside this module (fonts/, with its licence and SHA256SUMS) so
every site prints the same glyphs, accents, Greek and Cyrillic names included, whatever fonts the host has."""

from __future__ import annotations

import functools
import hashlib
from pathlib import Path

from fpdf import FPDF

from schemas.errors import InvalidInput

FAMILY = "DejaVu"
FOLDER = Path(__file__).with_name("fonts")
FILES = {"": "DejaVuSans.ttf", "B": "DejaVuSans-Bold.ttf"}
"""fpdf2 style ("" regular, "B" bold) -> file under FOLDER."""
SUMS = "SHA256SUMS"


def _expected_sums() -> dict[str, str]:
    path = FOLDER / SUMS
    try:
        lines = path.read_text(encoding="ascii").splitlines()
    except OSError as exc:
        raise InvalidInput(f"the report's font checksums {path} are missing ({exc}); reinstall burnedge") from exc
    sums = {}
    for line in lines:
        digest, _, name = line.strip().partition("  ")
        if name:
            sums[name] = digest
    return sums


@functools.cache
def check_fonts() -> None:
    """Raise InvalidInput naming the font file when one is missing or not the vendored one (sha256)."""
    sums = _expected_sums()
    for name in FILES.values():
        path = FOLDER / name
        if name not in sums:
            raise InvalidInput(f"{FOLDER / SUMS} lists no checksum for {name}; reinstall burnedge")
        try:
            digest = hashlib.sha256(path.read_bytes()).hexdigest()
        except OSError as exc:
            raise InvalidInput(f"the report font {path} is missing or unreadable ({exc}); reinstall burnedge") from exc
        if digest != sums[name]:
            raise InvalidInput(
                f"the report font {path} is not the vendored file (sha256 {digest}, expected {sums[name]}); "
                "reinstall burnedge"
            )


def add_fonts(pdf: FPDF) -> None:
    """Register DejaVu Sans regular and bold on `pdf` as FAMILY, after checking the files."""
    check_fonts()
    for style, name in FILES.items():
        pdf.add_font(FAMILY, style, fname=str(FOLDER / name))
