"""The burn chart for the browser pages: the Lund-Browder front and back views as SVG (body_geometry.py holds the
shapes the PDF draws too), each region its own path with its depth fill, a tooltip naming what was charted, and
optionally a link.

    body_chart_svg(entries, *, href=None, selected=None, title="Burn chart") -> str

A region charted at several depths is filled at its deepest, as in the PDF, and its label names every depth.
The depth is the clinician's category, never a measurement.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence

from processing.report.body_geometry import (
    DEPTH_FILL,
    DEPTH_HATCH,
    DEPTH_LEGEND,
    FRONT,
    OUTLINE,
    REGION_LABELS,
    REGION_POLYGONS,
    REGION_VIEW,
    UNCHARTED,
    view_boxes,
)
from processing.views.svg import element, num, path_d, rgb, svg_root, text, tooltip
from schemas.burn_chart import BurnChartEntry, BurnDepth, LundBrowderRegion
from schemas.errors import InvalidInput

__all__ = ["REGION_LABELS", "body_chart_svg", "chart_entries", "region_label"]

Charted = Mapping[LundBrowderRegion, Sequence[tuple[float, BurnDepth]]]
WIDTH = 150.0
VIEWS_TOP, VIEWS_HEIGHT = 4.0, 130.0
"""The box given to view_boxes: it keeps 5 above the views for their titles (4 more here) and 11 below them."""
LEGEND_ROW = 6.2
HATCH_STEP = 2.0
"""Hatch spacing in viewBox units: the PDF's 1.3 mm on its 38 mm wide view, scaled to this one's 57."""
OUTLINE_WIDTH, SELECTED_WIDTH = 0.35, 0.9
SELECTED = (0, 0, 0)
NOT_BURNED = "not burned"
_ORDER = list(BurnDepth)


def chart_entries(entries: Iterable[BurnChartEntry]) -> dict[LundBrowderRegion, list[tuple[float, BurnDepth]]]:
    """A BurnChart's entries as body_chart_svg takes them: region -> [(fraction, depth), ...] in charted order."""
    charted: dict[LundBrowderRegion, list[tuple[float, BurnDepth]]] = {}
    for entry in entries:
        charted.setdefault(LundBrowderRegion(entry.region), []).append((entry.fraction, BurnDepth(entry.depth)))
    return charted


def _checked(entries: Charted) -> dict[LundBrowderRegion, list[tuple[float, BurnDepth]]]:
    checked = {}
    for key, rows in entries.items():
        try:
            region = LundBrowderRegion(key)
            depths = [(float(fraction), BurnDepth(depth)) for fraction, depth in rows]
        except (TypeError, ValueError) as exc:
            raise InvalidInput(f"burn chart entry {key!r}: {exc}") from exc
        if not all(math.isfinite(f) and 0 <= f <= 1 for f, _ in depths):
            raise InvalidInput(f"burn chart entry {key!r}: every fraction must lie in 0..1, got {rows!r}")
        if depths:
            checked[region] = depths
    return checked


def _percent(fraction: float) -> str:
    return f"{round(100 * fraction, 1):g} %"


def region_label(region: LundBrowderRegion, rows: Sequence[tuple[float, BurnDepth]] = ()) -> str:
    """'Right thigh, front: 30 % deep partial thickness', deepest depth first; '...: not burned' when uncharted."""
    if not rows:
        return f"{REGION_LABELS[region]}: {NOT_BURNED}"
    ordered = sorted(rows, key=lambda row: -_ORDER.index(row[1]))
    return f"{REGION_LABELS[region]}: " + ", ".join(f"{_percent(f)} {DEPTH_LEGEND[d]}" for f, d in ordered)


def _deepest(rows: Sequence[tuple[float, BurnDepth]]) -> BurnDepth | None:
    return max((d for _, d in rows), key=_ORDER.index, default=None)


def _fill(depth: BurnDepth | None) -> str:
    if depth is None:
        return rgb(UNCHARTED)
    return f"url(#hatch-{depth.value})" if depth in DEPTH_HATCH else rgb(DEPTH_FILL[depth])


def _patterns() -> str:
    """One pattern per hatched depth: its colour with white lines at the PDF's angles."""
    patterns = []
    for depth, angles in DEPTH_HATCH.items():
        s = HATCH_STEP
        lines = [element("rect", {"width": num(s), "height": num(s), "fill": rgb(DEPTH_FILL[depth])})]
        for angle in angles:
            # The tile is turned 45°: a 45° hatch is its horizontal line, a -45° one its vertical line.
            end = {"x1": 0, "y1": num(s / 2), "x2": num(s), "y2": num(s / 2)} if angle > 0 else {}
            end = end or {"x1": num(s / 2), "y1": 0, "x2": num(s / 2), "y2": num(s)}
            lines.append(element("line", end | {"stroke": "#ffffff", "stroke-width": "0.35"}))
        attrs = {"id": f"hatch-{depth.value}", "patternUnits": "userSpaceOnUse", "width": num(s), "height": num(s)}
        patterns.append(element("pattern", attrs | {"patternTransform": "rotate(45)"}, *lines))
    return element("defs", None, *patterns)


def _region(region, box, rows, href, selected) -> str:
    bx, by, bw, bh = box
    depth = _deepest(rows)
    label = region_label(region, rows)
    is_selected = region == selected
    classes = ["region", f"depth-{depth.value}" if depth else "unburned"] + (["selected"] if is_selected else [])
    shape = element(
        "path",
        {
            "d": path_d((bx + x * bw, by + y * bh) for x, y in REGION_POLYGONS[region]),
            "data-region": region.value,
            "class": " ".join(classes),
            "fill": _fill(depth),
            "stroke": rgb(SELECTED if is_selected else OUTLINE),
            "stroke-width": num(SELECTED_WIDTH if is_selected else OUTLINE_WIDTH),
            "stroke-linejoin": "round",
        },
        tooltip(label),
    )
    if href is None:
        return shape
    link = {"href": href(region), "class": "region-link", "data-region": region.value, "aria-label": label}
    return element("a", link | {"aria-current": "true" if is_selected else None}, shape)


def _view_labels(boxes) -> list[str]:
    """'Front' / 'Back' over each view, the patient's right and left at its edges ('R' on the reader's left in the
    front view, on the reader's right in the back view)."""
    out = []
    for view, (bx, by, bw, _bh) in boxes.items():
        name = "Front" if view == FRONT else "Back"
        heading = {"x": num(bx + bw / 2), "y": num(by - 3), "text-anchor": "middle", "font-size": "4.6"}
        out.append(element("text", heading | {"font-weight": "bold"}, text(name)))
        left, right = ("R", "L") if view == FRONT else ("L", "R")
        for side, x, anchor in ((left, bx, "start"), (right, bx + bw, "end")):
            words = "the patient's right" if side == "R" else "the patient's left"
            attrs = {"x": num(x), "y": num(by - 3), "text-anchor": anchor, "font-size": "4", "fill": "#404040"}
            out.append(element("text", attrs, tooltip(words), text(side)))
    return out


def _legend(top: float) -> tuple[list[str], float]:
    """Swatches of the four depths and of an uncharted region, in two columns; returns them and their bottom."""
    items: list[tuple[BurnDepth | None, str]] = [(d, DEPTH_LEGEND[d]) for d in BurnDepth] + [(None, NOT_BURNED)]
    out = []
    for i, (depth, label) in enumerate(items):
        x, y = 6 + (i // 3) * WIDTH / 2, top + (i % 3) * LEGEND_ROW
        swatch = {"x": num(x), "y": num(y), "width": "7", "height": "4.2", "fill": _fill(depth)}
        out.append(element("rect", swatch | {"stroke": rgb(OUTLINE), "stroke-width": num(OUTLINE_WIDTH)}))
        out.append(element("text", {"x": num(x + 9), "y": num(y + 3.4), "font-size": "3.8"}, text(label)))
    return out, top + 3 * LEGEND_ROW


def body_chart_svg(
    entries: Charted,
    *,
    href: Callable[[LundBrowderRegion], str] | None = None,
    selected: LundBrowderRegion | None = None,
    title: str = "Burn chart",
) -> str:
    """The chart as one `<svg>` element. `entries`: region -> [(fraction 0..1, depth), ...] as charted;
    `href(region)`: each region becomes a link to that URL; `selected`: that region is outlined thick."""
    charted = _checked(entries)
    if selected is not None and selected not in REGION_POLYGONS:
        raise InvalidInput(f"the selected region {selected!r} is not a Lund-Browder region")
    boxes = view_boxes(0.0, VIEWS_TOP, WIDTH, VIEWS_HEIGHT)
    order = [r for r in REGION_POLYGONS if r != selected] + ([selected] if selected in REGION_POLYGONS else [])
    regions = [_region(r, boxes[REGION_VIEW[r]], charted.get(r, []), href, selected) for r in order]
    legend, bottom = _legend(max(by + bh for _, by, _, bh in boxes.values()) + 4.5)
    count = len(charted)
    summary = f"{title}: {count} region{'' if count == 1 else 's'} charted"
    details = "; ".join(region_label(r, charted[r]) for r in REGION_POLYGONS if r in charted)
    head = [
        element("title", None, text(title)),
        element("desc", None, text(summary + (f". {details}." if details else "."))),
    ]
    attrs = {"class": "body-chart", "role": "group" if href else "img", "aria-label": summary}
    body = [_patterns(), element("g", {"class": "regions"}, *regions)]
    body += [element("g", {"class": "view-labels"}, *_view_labels(boxes)), element("g", {"class": "legend"}, *legend)]
    return svg_root(WIDTH, bottom + 1.0, attrs, *head, *body)
