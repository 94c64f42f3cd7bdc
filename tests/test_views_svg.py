"""The browser pages' SVG drawings: well-formed XML, every chart region once with its label and link, text escaped,
and healing plots that draw what was measured and nothing more."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import pytest

from processing.report.body_geometry import REGION_LABELS, REGION_VIEW
from processing.report.healing_series import Closure
from processing.views.body_chart_svg import body_chart_svg, chart_entries
from processing.views.healing_plot_svg import ONE_VISIT, healing_plot_svg, healing_plots_svg
from schemas.burn_chart import BurnChartEntry, BurnDepth, LundBrowderRegion
from schemas.errors import InvalidInput
from schemas.longitudinal import TrackResult, TrackSession

NS = {"s": "http://www.w3.org/2000/svg"}
R, D = LundBrowderRegion, BurnDepth
CHARTED = {
    R.thigh_right_anterior: [(0.3, D.deep_partial)],
    R.trunk_anterior: [(0.2, D.superficial), (0.5, D.full_thickness)],
    R.buttock_left: [(1.0, D.superficial_partial)],
}


def _parse(svg: str) -> ET.Element:
    root = ET.fromstring(svg)
    assert root.tag == "{http://www.w3.org/2000/svg}svg"
    assert root.get("viewBox") and root.get("preserveAspectRatio") and root.get("width") == "100%"
    assert "<script" not in svg and " style=" not in svg and "<style" not in svg
    return root


def _regions(root: ET.Element) -> dict[str, ET.Element]:
    shapes = root.findall(".//s:path[@data-region]", NS)
    names = [s.get("data-region") for s in shapes]
    assert sorted(names) == sorted(r.value for r in LundBrowderRegion)  # each region exactly once
    return dict(zip(names, shapes, strict=True))


def test_every_region_is_one_labelled_path_filled_at_its_deepest_depth():
    root = _parse(body_chart_svg(CHARTED))
    shapes = _regions(root)
    thigh = shapes["thigh_right_anterior"]
    assert thigh.find("s:title", NS).text == "Right thigh, front: 30 % deep partial thickness"
    assert "depth-deep_partial" in thigh.get("class").split() and thigh.get("fill") == "url(#hatch-deep_partial)"
    trunk = shapes["trunk_anterior"]
    assert "depth-full_thickness" in trunk.get("class").split()
    assert trunk.find("s:title", NS).text == "Trunk, front: 50 % full thickness, 20 % superficial (epidermal)"
    buttock = shapes["buttock_left"]
    assert (
        buttock.get("fill") == "#eb8c32" and "100 % superficial partial thickness" in buttock.find("s:title", NS).text
    )
    head = shapes["head_posterior"]
    assert "unburned" in head.get("class").split() and head.find("s:title", NS).text == "Head, back: not burned"
    assert {p.get("id") for p in root.findall(".//s:defs/s:pattern", NS)} == {
        "hatch-deep_partial",
        "hatch-full_thickness",
    }
    assert root.get("aria-label") == "Burn chart: 3 regions charted" and root.get("role") == "img"
    assert root.find("s:desc", NS).text.startswith("Burn chart: 3 regions charted. ")
    assert not root.findall(".//s:a", NS)


def test_views_and_the_patients_sides_are_labelled():
    root = _parse(body_chart_svg({}))
    texts = [("".join(t.itertext()), float(t.get("x"))) for t in root.iter("{http://www.w3.org/2000/svg}text")]
    words = [w for w, _ in texts]
    assert "Front" in words and "Back" in words and root.get("aria-label") == "Burn chart: 0 regions charted"
    # Front: the patient's right on the reader's left; back: on the reader's right.
    sides = [(w.removeprefix("the patient's right").removeprefix("the patient's left"), x) for w, x in texts]
    sides = [(w, x) for w, x in sides if w in ("R", "L")]
    assert [w for w, _ in sorted(sides, key=lambda s: s[1])] == ["R", "L", "L", "R"]
    assert set(REGION_LABELS) == set(LundBrowderRegion) and len(set(REGION_LABELS.values())) == len(REGION_LABELS)
    assert set(REGION_VIEW) == set(LundBrowderRegion)


def test_links_wrap_each_region_and_the_selected_one_is_marked():
    svg = body_chart_svg(CHARTED, href=lambda r: f"/chart/{r.value}?from=chart&x=1", selected=R.buttock_left)
    root = _parse(svg)
    links = root.findall(".//s:a", NS)
    assert len(links) == len(LundBrowderRegion) and root.get("role") == "group"
    by_region = {a.get("data-region"): a for a in links}
    link = by_region["thigh_right_anterior"]
    assert link.get("href") == "/chart/thigh_right_anterior?from=chart&x=1" and "&amp;x=1" in svg
    assert link.get("class") == "region-link" and link.get("aria-label").startswith("Right thigh, front: 30 %")
    assert link.find("s:path", NS).get("data-region") == "thigh_right_anterior"
    selected = [p for p in _regions(root).values() if "selected" in p.get("class").split()]
    assert [p.get("data-region") for p in selected] == ["buttock_left"]
    assert by_region["buttock_left"].get("aria-current") == "true"


def test_text_is_escaped():
    hostile = 'Chart <script>alert("x")</script> & co'
    svg = body_chart_svg(CHARTED, title=hostile, href=lambda r: f'/x?"><script>{r.value}')
    root = _parse(svg)
    assert root.find("s:title", NS).text == hostile and "&lt;script&gt;" in svg
    plot = healing_plot_svg(points=[(1, 2.0)], title=hostile, y_label="<b>cm²</b>", note="<i>n</i>")
    root = _parse(plot)
    assert root.find("s:title", NS).text == hostile and "&lt;b&gt;cm²&lt;/b&gt;" in plot


def test_chart_entries_group_a_charts_rows_and_bad_fractions_are_refused():
    rows = [
        BurnChartEntry(region=R.hand_left_dorsal, fraction=0.4, depth=D.superficial),
        BurnChartEntry(region=R.hand_left_dorsal, fraction=0.1, depth=D.deep_partial),
    ]
    assert chart_entries(rows) == {R.hand_left_dorsal: [(0.4, D.superficial), (0.1, D.deep_partial)]}
    shape = _regions(_parse(body_chart_svg(chart_entries(rows))))["hand_left_dorsal"]
    assert (
        shape.find("s:title", NS).text == "Left hand, back: 10 % deep partial thickness, 40 % superficial (epidermal)"
    )
    with pytest.raises(InvalidInput, match="0..1"):
        body_chart_svg({R.genitalia: [(1.5, D.superficial)]})
    with pytest.raises(InvalidInput):
        body_chart_svg({"elbow": [(0.5, D.superficial)]})
    with pytest.raises(InvalidInput, match="selected"):
        body_chart_svg({}, selected="elbow")


POINTS = [(2.0, 41.3), (6.0, 33.0), (10.0, 24.8), (15.0, 14.1)]


def test_the_healing_plot_draws_each_visit_the_fit_and_the_projected_closure():
    closure = Closure(21.7, 18.0, 27.0)
    root = _parse(
        healing_plot_svg(
            points=POINTS,
            title="Burn area",
            y_label="cm²",
            unit="cm²",
            digits=1,
            fit=(45.2, -2.1),
            closure=closure,
            marks=[(21.0, "day 21")],
        )
    )
    circles = root.findall(".//s:circle[@class='visit']", NS)
    assert len(circles) == 4 and circles[0].find("s:title", NS).text == "day 2: 41.3 cm²"
    assert len(root.findall(".//s:polyline", NS)) == 1
    fit = root.find(".//s:line[@class='fit']", NS)
    assert fit is not None and fit.get("stroke-dasharray")
    group = root.find(".//s:g[@class='closure']", NS)
    assert group.find("s:rect[@class='closure-range']", NS) is not None
    words = " ".join("".join(t.itertext()) for t in group.iter("{http://www.w3.org/2000/svg}text"))
    assert "projected closure day 22 (95 % range 18 to 27)" in words
    assert "extrapolation" in root.find("s:desc", NS).text
    texts = {"".join(t.itertext()) for t in root.iter("{http://www.w3.org/2000/svg}text")}
    assert {"0", "5", "10", "25", "50", "day 21", "days since injury", "cm²"} <= texts


@pytest.mark.parametrize("n", [0, 1])
def test_under_two_visits_draws_axes_and_says_so_never_a_line(n):
    root = _parse(
        healing_plot_svg(
            points=POINTS[:n], title="Burn area", y_label="cm²", fit=(45.2, -2.1), closure=Closure(21.7, 18.0, 27.0)
        )
    )
    assert len(root.findall(".//s:circle[@class='visit']", NS)) == n
    assert not root.findall(".//s:polyline", NS) and root.find(".//s:line[@class='fit']", NS) is None
    assert root.find(".//s:g[@class='closure']", NS) is None and root.find(".//s:g[@class='axes']", NS) is not None
    message = " ".join("".join(t.itertext()) for t in root.find(".//s:g[@class='message']", NS))
    assert message == (ONE_VISIT if n else "no measured visits")


def _session(day, area, relief=None, volume=None, status="ok"):
    return TrackSession(
        day=day, label=f"day {day}", analysis="a", status=status, area_cm2=area, relief_max_mm=relief, volume_cm3=volume
    )


def test_healing_plots_of_a_track_take_the_pdfs_figures_and_leave_unscaled_visits_out():
    sessions = [_session(d, a, a / 10, a / 8) for d, a in POINTS] + [_session(18.0, None, status="unscaled")]
    track = TrackResult(
        sessions=sessions,
        healing_rate_cm2_per_day=2.1,
        projected_closure_day=21.7,
        projected_closure_range_days=[18.0, None],
    )
    plots = healing_plots_svg(track)
    assert [t for t, _ in plots] == ["Burn area", "Deepest relief (geometry)", "Volume below reference"]
    area, relief, volume = (_parse(svg) for _, svg in plots)
    tips = [c.find("s:title", NS).text for c in area.findall(".//s:circle[@class='visit']", NS)]
    assert tips == ["day 2: 41.30 cm²", "day 6: 33.00 cm²", "day 10: 24.80 cm²", "day 15: 14.10 cm²"]
    assert area.find(".//s:line[@class='fit']", NS) is not None and area.find(".//s:g[@class='closure']", NS)
    assert "95 % range 18 to open" in area.find("s:desc", NS).text
    assert relief.find(".//s:circle[@class='visit']/s:title", NS).text == "day 2: 4.1 mm"
    assert volume.find(".//s:circle[@class='visit']/s:title", NS).text == "day 2: 5.16 cm³"
    assert relief.find(".//s:line[@class='fit']", NS) is None and relief.find(".//s:g[@class='closure']", NS) is None
    assert "not in cm or mm" in area.find("s:desc", NS).text


def test_a_track_with_no_scaled_visit_plots_nothing_in_cm():
    track = TrackResult(sessions=[_session(3.0, None, status="unscaled"), _session(9.0, 12.0, status="unscaled")])
    for _, svg in healing_plots_svg(track):
        root = _parse(svg)
        assert not root.findall(".//s:circle[@class='visit']", NS) and "12.0" not in svg
        message = [("".join(t.itertext())) for t in root.find(".//s:g[@class='message']", NS)]
        assert message[0] == "no measured visits" and "not in cm or mm" in message[1]


def test_a_plot_refuses_numbers_it_cannot_place():
    with pytest.raises(InvalidInput, match="finite"):
        healing_plot_svg(points=[(1.0, float("nan")), (3.0, 2.0)], title="t", y_label="mm")
    with pytest.raises(InvalidInput, match="start at 0"):
        healing_plot_svg(points=[(-2.0, 1.0)], title="t", y_label="mm")
