"""The printable marker sheet and the capture settings a phone checks by, over the real app without signing in: the
print is measured as a printer would make it (pdftoppm at 300 dpi) and its markers found by the gateway's detector."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import cv2
import numpy as np
import pytest

from processing.report.marker_sheet import CHECK_LINE_MM, Paper, render
from schemas.errors import InvalidInput

DPI = 150
"""About a phone photo's pixels per marker (20 mm is 118 px): the detector is made for that, not for 300 dpi scans."""
MM_PER_PX = 25.4 / DPI

needs_poppler = pytest.mark.skipif(shutil.which("pdftoppm") is None, reason="pdftoppm (poppler-utils) is not installed")


def _printed(pdf: bytes, tmp_path: Path) -> np.ndarray:
    (tmp_path / "sheet.pdf").write_bytes(pdf)
    subprocess.run(["pdftoppm", "-r", str(DPI), "-gray", tmp_path / "sheet.pdf", tmp_path / "page"], check=True)
    return cv2.imread(str(next(tmp_path.glob("page*.pgm"))), cv2.IMREAD_GRAYSCALE)


def _markers(gray: np.ndarray, dictionary: str) -> dict[int, float]:
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
    detector = cv2.aruco.ArucoDetector(cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, dictionary)), params)
    corners, ids, _ = detector.detectMarkers(gray)
    sides = {}
    for marker_id, quad in zip(ids.ravel().tolist(), corners, strict=True):
        q = quad.reshape(4, 2)
        sides[marker_id] = float(np.mean([np.linalg.norm(q[i] - q[(i + 1) % 4]) for i in range(4)])) * MM_PER_PX
    return sides


def _longest_line_mm(gray: np.ndarray) -> float:
    """The longest horizontal run of dark pixels on the page: the check line."""
    dark = gray < 100
    best = 0
    for row in dark:
        padded = np.concatenate(([0], row.astype(np.int8), [0]))
        edges = np.flatnonzero(np.diff(padded))
        if len(edges):
            best = max(best, int((edges[1::2] - edges[::2]).max()))
    return best * MM_PER_PX


@needs_poppler
@pytest.mark.parametrize("paper", list(Paper))
def test_the_printed_markers_are_the_configured_size_and_the_check_line_is_10_cm(tmp_path: Path, paper: Paper):
    gray = _printed(render("DICT_4X4_50", 20.0, paper), tmp_path)
    sides = _markers(gray, "DICT_4X4_50")
    assert sorted(sides) == list(range(len(sides))) and len(sides) >= 18  # six strips of three at least
    # 0.1 mm is 0.6 px at 150 dpi: the corner refinement's error, not the print's.
    assert all(abs(side - 20.0) < 0.1 for side in sides.values()), sides
    assert _longest_line_mm(gray) == pytest.approx(CHECK_LINE_MM, abs=0.3)


@needs_poppler
def test_another_dictionary_and_size_print_as_configured(tmp_path: Path):
    sides = _markers(_printed(render("DICT_5X5_100", 30.0), tmp_path), "DICT_5X5_100")
    assert len(sides) >= 9 and all(abs(side - 30.0) < 0.1 for side in sides.values())


def test_a_sheet_that_cannot_be_printed_is_refused_with_the_reason():
    with pytest.raises(InvalidInput, match="DICT_9X9"):
        render("DICT_9X9_50", 20.0)
    with pytest.raises(InvalidInput, match="5 to 60 mm"):
        render("DICT_4X4_50", 80.0)


@needs_poppler
def test_the_sheet_and_the_settings_are_served_without_signing_in(client, config, tmp_path: Path):
    sheet = client.get("/marker-sheet.pdf")
    assert sheet.status_code == 200 and sheet.headers["content-type"] == "application/pdf"
    (tmp_path / "sheet.pdf").write_bytes(sheet.content)
    text = subprocess.run(["pdftotext", tmp_path / "sheet.pdf", "-"], capture_output=True, check=True, text=True)
    words = " ".join(text.stdout.split())
    assert "Print at 100 %" in words and "Check line: 10 cm" in words and "never on the burn itself" in words
    assert "DICT_4X4_50" in words and "20 mm" in words
    assert client.get("/marker-sheet.pdf?paper=letter").status_code == 200
    wrong = client.get("/marker-sheet.pdf?paper=folio")
    assert wrong.status_code == 400 and "paper" in wrong.text

    settings = client.get("/api/v1/capture/settings")
    assert settings.status_code == 200
    body = settings.json()
    assert body["quality"]["min_local_sharpness"] == config.quality.min_local_sharpness
    assert body["readiness"]["min_views"] == config.readiness.min_views
    marker = body["marker"]
    assert (marker["dictionary"], marker["side_mm"], marker["sheet"]) == ("DICT_4X4_50", 20.0, "/marker-sheet.pdf")
    # The phone's detector reads the gateway's own dictionary: each code is the marker's bits (white = 1, as
    # OpenCV draws them), row by row.
    aruco = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50)
    assert (marker["bits"], len(marker["codes"])) == (16, 50)
    for marker_id in (0, 7, 49):
        drawn = cv2.aruco.generateImageMarker(aruco, marker_id, 6, borderBits=1)[1:5, 1:5] > 127
        assert format(int(marker["codes"][marker_id], 16), "016b") == "".join("1" if b else "0" for b in drawn.ravel())
    assert body["guidance"]["blurry"].startswith("Hold the phone still") and "blurry" in body["rejecting"]
