"""Reading a clinical report back as a person would: every page rasterised, the text extracted."""

from __future__ import annotations

import io
import shutil
import subprocess
from pathlib import Path

import cv2
import numpy as np


def page_texts(pdf: bytes) -> list[str]:
    from pypdf import PdfReader

    return [page.extract_text() or "" for page in PdfReader(io.BytesIO(pdf)).pages]


def rasterise(pdf: bytes, folder: Path, dpi: int = 50) -> list[Path]:
    """Every page as a PNG (pdftoppm, Debian's poppler-utils); [] when pdftoppm is not installed."""
    if shutil.which("pdftoppm") is None:
        return []
    folder.mkdir(parents=True, exist_ok=True)
    source = folder / "report.pdf"
    source.write_bytes(pdf)
    subprocess.run(["pdftoppm", "-r", str(dpi), "-png", str(source), str(folder / "page")], check=True, timeout=120)
    return sorted(folder.glob("page-*.png"))


def inked_share(png: Path, footer_mm: float = 22.0) -> float:
    """Share of the page above the footer that is not white."""
    page = cv2.imread(str(png), cv2.IMREAD_GRAYSCALE)
    body = page[: int(page.shape[0] * (1 - footer_mm / 297.0))]
    return float(np.mean(body < 200))
