"""Helpers for tests that start from a rendered phantom."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np

SMALL = {"views": 8, "width": 960, "height": 720}
"""A small multi-view set: about 20 s per analysis on two cores."""


def render_small_patch(out: Path) -> Path:
    """The phantom the analysis tests share: a patch with a 16 cm2, 2.5 mm deep burn, SMALL views."""
    from harness.phantoms import rendered
    from schemas.phantom import PhantomShape, PhantomSpec

    return rendered(PhantomSpec(shape=PhantomShape.patch, seed=12, area_cm2=16.0, depth_mm=2.5, **SMALL), out)


def hide_marker(phantom: Path, images: Path) -> None:
    """Paint over the marker strip in every picture, as if none had been laid down."""
    truth = json.loads((phantom / "ground_truth.json").read_text())
    corners = np.vstack([np.array(c) for c in truth["marker"]["corners_world_mm"].values()])
    centre = corners.mean(axis=0)
    strip = centre + (corners - centre) * 1.6
    for camera in truth["cameras"]:
        path = images / f"{camera['name']}.jpg"
        if not path.exists():
            continue  # left out by the quality gate
        image = cv2.imread(str(path))
        cam = strip @ np.array(camera["R"]).T + np.array(camera["t"])
        uv = cam[:, :2] / cam[:, 2:] @ np.array(camera["K"])[:2, :2].T + np.array(camera["K"])[:2, 2]
        cv2.fillConvexPoly(image, cv2.convexHull(uv.astype(np.int32)), (90, 110, 140))
        cv2.imwrite(str(path), image, [cv2.IMWRITE_JPEG_QUALITY, 95])
