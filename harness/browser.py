"""A real browser for the page tests: Playwright for Python driving Debian's Chromium (Playwright's own browser
download cannot reach the internet), headless, with software WebGL so the 3D viewer renders without a GPU.
Screenshots go to test-artifacts/browser/ (or $BURNEDGE_TEST_ARTIFACTS); with BURNEDGE_UPDATE_SCREENSHOTS=1 the
ones the README shows are saved to docs/images/ as well (the first screenful)."""

from __future__ import annotations

import os
from pathlib import Path

import cv2
import numpy as np

from harness.processes import REPO

CHROMIUM = Path(os.environ.get("BURNEDGE_CHROMIUM", "/usr/bin/chromium"))
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
]
ARTIFACTS = Path(os.environ.get("BURNEDGE_TEST_ARTIFACTS", REPO / "test-artifacts")) / "browser"
README_IMAGES = REPO / "docs" / "images"
PHONE, TABLET, DESKTOP = (390, 844), (768, 1024), (1280, 900)


def browser_missing() -> str:
    """Why the browser tests cannot run here ('' when they can)."""
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return "Playwright is not installed (pip install -e '.[test]')"
    if not CHROMIUM.exists():
        return f"no Chromium at {CHROMIUM} (bash deploy/bootstrap.sh --test installs Debian's chromium)"
    return ""


def launch(playwright):
    return playwright.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS, headless=True)


def shot(page, name: str, *, full_page: bool = True, readme: str | None = None) -> Path:
    """Save a screenshot of the page as a test artifact (and as docs/images/<readme> when asked to)."""
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    path = ARTIFACTS / f"{name}.png"
    page.screenshot(path=str(path), full_page=full_page)
    if readme and os.environ.get("BURNEDGE_UPDATE_SCREENSHOTS") == "1":
        # What a person sees on opening the page: the first screenful, not the whole scroll.
        README_IMAGES.mkdir(parents=True, exist_ok=True)
        page.screenshot(path=str(README_IMAGES / readme), full_page=False)
    return path


def distinct_colours(png: Path) -> int:
    """How many different colours an image has: a blank canvas has one or two, a rendered surface thousands."""
    image = cv2.imread(str(png), cv2.IMREAD_COLOR)
    if image is None:
        raise AssertionError(f"{png} is not an image")
    packed = image.reshape(-1, 3).astype(np.uint32) @ np.array([1 << 16, 1 << 8, 1], dtype=np.uint32)
    return int(np.unique(packed).size)
