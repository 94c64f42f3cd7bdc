"""Finding the printed ArUco scale marker in a picture."""

from __future__ import annotations

import functools

import cv2
import numpy as np

from schemas.capture import MarkerSighting
from schemas.errors import InvalidInput


@functools.cache
def _detector(dictionary: str) -> cv2.aruco.ArucoDetector:
    code = getattr(cv2.aruco, dictionary, None)
    if not isinstance(code, int) or not dictionary.startswith("DICT_"):
        raise InvalidInput(f"unknown ArUco dictionary {dictionary!r}: use an OpenCV name such as DICT_4X4_50")
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
    # Two adaptive-threshold windows instead of three: half the time, and every marker in the
    # shared phantom views (53 of 54; the 54th is half hidden) is still found.
    params.adaptiveThreshWinSizeMin, params.adaptiveThreshWinSizeMax, params.adaptiveThreshWinSizeStep = 9, 19, 10
    return cv2.aruco.ArucoDetector(cv2.aruco.getPredefinedDictionary(code), params)


def find_markers(gray: np.ndarray, scale: float, dictionary: str) -> list[MarkerSighting]:
    """Markers in `gray` (scale = gray pixels per full-resolution pixel), reported in full-resolution pixels."""
    corners, ids, _ = _detector(dictionary).detectMarkers(gray)
    if ids is None:
        return []
    found = []
    for marker_id, quad in zip(ids.ravel().tolist(), corners, strict=True):
        pts = quad.reshape(4, 2) / scale
        side = float(np.mean([np.linalg.norm(pts[i] - pts[(i + 1) % 4]) for i in range(4)]))
        found.append(MarkerSighting(id=int(marker_id), side_px=round(side, 2), corners_px=pts.round(2).tolist()))
    return sorted(found, key=lambda m: m.id)
