"""The Lund-Browder body chart's geometry, shared by the PDF report and the browser pages: one closed polygon per
region in its view's unit box, where the two views lie, a point inside each region for its label, the depth
colours and the human names of the regions. Pure: no drawing library.

Front view: the patient faces the reader, so the patient's right is on the reader's left; palms (anatomical
position), the tops of the feet (dorsal) and the genitalia are in it. Back view: the patient's right is on the
reader's right; the backs of the hands (dorsal), the buttocks and the soles (plantar, drawn as the feet under the
back view's legs) are in it.
"""

from __future__ import annotations

import math

from schemas.burn_chart import REGION_NAMES, BurnDepth, LundBrowderRegion

R = LundBrowderRegion
FRONT, BACK = "front", "back"
ASPECT = 0.5
"""Width / height of one view's unit box as drawn."""

DEPTH_FILL: dict[BurnDepth, tuple[int, int, int]] = {
    # Lightness falls with depth (greyscale 207, 158, 89, 35), so a black-and-white copy keeps the order.
    BurnDepth.superficial: (246, 196, 160),
    BurnDepth.superficial_partial: (235, 140, 50),
    BurnDepth.deep_partial: (205, 38, 38),
    BurnDepth.full_thickness: (62, 18, 40),
}
DEPTH_HATCH: dict[BurnDepth, tuple[float, ...]] = {
    # Hatch angles (degrees) on the two deep categories: a second cue where a copier flattens dark greys.
    BurnDepth.deep_partial: (45.0,),
    BurnDepth.full_thickness: (45.0, -45.0),
}
DEPTH_LEGEND = {
    BurnDepth.superficial: "superficial (epidermal)",
    BurnDepth.superficial_partial: "superficial partial thickness",
    BurnDepth.deep_partial: "deep partial thickness",
    BurnDepth.full_thickness: "full thickness",
}
OUTLINE = (125, 125, 125)
UNCHARTED = (255, 255, 255)


def _ellipse(cx: float, cy: float, rx: float, ry: float, y_max: float, n: int = 20) -> list[tuple[float, float]]:
    pts = [(cx + rx * math.sin(2 * math.pi * i / n), cy - ry * math.cos(2 * math.pi * i / n)) for i in range(n)]
    return [(x, min(y, y_max)) for x, y in pts]


# One half of the figure, the reader's left, on a 50 x 100 grid (x right, y down); the other half is its mirror.
# Shared edges use the same points, so neighbouring regions meet without gaps or overlaps.
_HALF = {
    "upper_arm": [(15.5, 18.2), (12.8, 19.2), (11.2, 23), (10.2, 31), (9, 40), (12.3, 41), (13.9, 33), (16.5, 27)],
    "lower_arm": [(9, 40), (12.3, 41), (11.2, 48), (8.9, 56.5), (6.1, 56), (7.4, 48)],
    "hand": [
        (6.1, 56),
        (8.9, 56.5),
        (9.3, 60.5),
        (8.5, 64.5),
        (6.8, 65.5),
        (5.2, 64),
        (4.8, 61),
        (3.7, 59.2),
        (5.3, 58.4),
    ],
    "thigh_front": [(16, 49), (23, 51.5), (24.2, 54.5), (23.3, 73), (17.3, 73), (15.4, 60)],
    "thigh_back": [(16, 53), (19, 56.8), (24, 57.3), (23.3, 73), (17.3, 73), (15.4, 60)],
    "buttock": [(17, 44), (25, 45.5), (25, 55), (24, 57.3), (19, 56.8), (16, 53), (16, 49)],
    "lower_leg": [(17.3, 73), (23.3, 73), (22.6, 81), (22.5, 90.5), (19.3, 90.5), (17.6, 81)],
    "foot_dorsal": [(19.3, 90.5), (22.5, 90.5), (23.4, 94), (23.2, 97.5), (17.6, 97.5), (17.4, 96), (19, 93.5)],
    "foot_plantar": [(19.3, 90.5), (22.5, 90.5), (22.9, 93), (22.8, 97.8), (20.9, 98.8), (19, 97.8), (18.8, 93)],
}
_TRUNK_SIDE = [(22, 17), (15.5, 18.2), (16.5, 27), (17.5, 37), (17, 44), (16, 49)]
_HEAD = _ellipse(25, 7, 5, 6.6, 12.6)
_NECK = [(22.5, 12.6), (27.5, 12.6), (28, 17), (22, 17)]
_TRUNK_FRONT = _TRUNK_SIDE + [(23, 51.5), (27, 51.5)] + [(50 - x, y) for x, y in reversed(_TRUNK_SIDE)]
_TRUNK_BACK = _TRUNK_SIDE[:-1] + [(25, 45.5)] + [(50 - x, y) for x, y in reversed(_TRUNK_SIDE[:-1])]
_GENITALIA = [(23, 51.5), (27, 51.5), (25.8, 54.5), (25, 56.5), (24.2, 54.5)]


def _unit(points) -> list[tuple[float, float]]:
    return [(round(x / 50, 4), round(y / 100, 4)) for x, y in points]


def _mirror(points) -> list[tuple[float, float]]:
    return [(50 - x, y) for x, y in points]


def _limbs(view: str, side: str, reader_left: bool) -> dict[LundBrowderRegion, list[tuple[float, float]]]:
    """One side's limbs in one view; `side` is the patient's side drawn on the reader's left when reader_left."""
    face = "anterior" if view == FRONT else "posterior"
    parts = {
        R(f"upper_arm_{side}_{face}"): _HALF["upper_arm"],
        R(f"lower_arm_{side}_{face}"): _HALF["lower_arm"],
        R(f"hand_{side}_{'palmar' if view == FRONT else 'dorsal'}"): _HALF["hand"],
        R(f"thigh_{side}_{face}"): _HALF["thigh_front" if view == FRONT else "thigh_back"],
        R(f"lower_leg_{side}_{face}"): _HALF["lower_leg"],
        R(f"foot_{side}_{'dorsal' if view == FRONT else 'plantar'}"): _HALF[
            "foot_dorsal" if view == FRONT else "foot_plantar"
        ],
    }
    if view == BACK:
        parts[R(f"buttock_{side}")] = _HALF["buttock"]
    return {region: _unit(pts if reader_left else _mirror(pts)) for region, pts in parts.items()}


def _polygons() -> tuple[dict[LundBrowderRegion, list[tuple[float, float]]], dict[LundBrowderRegion, str]]:
    front = {R.head_anterior: _HEAD, R.neck_anterior: _NECK, R.trunk_anterior: _TRUNK_FRONT, R.genitalia: _GENITALIA}
    back = {R.head_posterior: _HEAD, R.neck_posterior: _NECK, R.trunk_posterior: _TRUNK_BACK}
    by_view = {
        FRONT: {r: _unit(p) for r, p in front.items()} | _limbs(FRONT, "right", True) | _limbs(FRONT, "left", False),
        BACK: {r: _unit(p) for r, p in back.items()} | _limbs(BACK, "left", True) | _limbs(BACK, "right", False),
    }
    polygons = {region: poly for regions in by_view.values() for region, poly in regions.items()}
    views = {region: view for view, regions in by_view.items() for region in regions}
    return polygons, views


REGION_POLYGONS, REGION_VIEW = _polygons()
"""Region -> closed polygon in its view's unit box (x right, y down, 0..1); region -> FRONT or BACK."""


def region_polygons() -> dict[LundBrowderRegion, list[tuple[float, float]]]:
    """Region -> closed polygon in its view's unit box (x right, y down, 0..1), a copy; `REGION_VIEW` names the view."""
    return {region: list(poly) for region, poly in REGION_POLYGONS.items()}


def view_boxes(x: float, y: float, w: float, h: float) -> dict[str, tuple[float, float, float, float]]:
    """Where each view's box (x, y, w, h) lies for a chart drawn in the box (x, y, w, h), in mm on the PDF: the two
    views side by side, 5 above them for the titles and 11 below for a two-row legend."""
    title, legend = 5.0, 11.0
    vh = max(h - title - legend, 10.0)
    vw = min(vh * ASPECT, (w - 14) / 2)
    vh = vw / ASPECT
    gap = (w - 2 * vw) / 3
    top = y + title
    return {FRONT: (x + gap, top, vw, vh), BACK: (x + 2 * gap + vw, top, vw, vh)}


def region_point(region: LundBrowderRegion, x: float, y: float, w: float, h: float) -> tuple[float, float]:
    """A point well inside `region` on the page (mm) for a chart drawn at (x, y, w, h)."""
    bx, by, bw, bh = view_boxes(x, y, w, h)[REGION_VIEW[region]]
    ux, uy = inner_point(REGION_POLYGONS[region])
    return bx + ux * bw, by + uy * bh


def inside(px: float, py: float, poly) -> bool:
    """Whether (px, py) lies inside the closed polygon (even-odd crossings)."""
    hit = False
    for (x1, y1), (x2, y2) in zip(poly, poly[1:] + poly[:1], strict=True):
        if (y1 > py) != (y2 > py) and px < x1 + (py - y1) * (x2 - x1) / (y2 - y1):
            hit = not hit
    return hit


def _edge_distance(px: float, py: float, poly) -> float:
    best = math.inf
    for (x1, y1), (x2, y2) in zip(poly, poly[1:] + poly[:1], strict=True):
        dx, dy = x2 - x1, (y2 - y1) / ASPECT
        t = max(0.0, min(1.0, ((px - x1) * dx + (py - y1) / ASPECT * dy) / (dx * dx + dy * dy or 1.0)))
        best = min(best, math.hypot(px - x1 - t * dx, (py - y1) / ASPECT - t * dy))
    return best


def inner_point(poly) -> tuple[float, float]:
    """The grid point inside the polygon farthest from its edges (the centroid can fall outside a bent limb)."""
    xs, ys = [p[0] for p in poly], [p[1] for p in poly]
    candidates = [
        (min(xs) + (max(xs) - min(xs)) * i / 24, min(ys) + (max(ys) - min(ys)) * j / 24)
        for i in range(1, 24)
        for j in range(1, 24)
    ]
    return max((c for c in candidates if inside(*c, poly)), key=lambda c: _edge_distance(*c, poly))


REGION_LABELS = REGION_NAMES
"""Region -> its name for a reader (schemas.burn_chart.REGION_NAMES)."""
