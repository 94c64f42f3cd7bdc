"""Healing over time in the report: one section per wound, with its measured share of the body beside the chart."""

from __future__ import annotations

from processing.report.figures import figure
from processing.report.healing_series import healing_series
from processing.report.layout import GREY, URGENT, ReportPDF
from processing.report.plots import line_plot
from schemas.encounter_snapshot import EncounterSnapshot
from schemas.wound_healing import SHARE_SOURCES, BodyShare, WoundHealing


def healing(pdf: ReportPDF, r: EncounterSnapshot) -> None:
    """Healing over time, one section per wound: each wound's own visits, never mixed."""
    tracked = [w for w in r.healing if w.track is not None and w.track.sessions]
    if not tracked:
        pdf.heading("Healing over time")
        pdf.para("No measured visit yet: the healing track starts with the first analysis.", colour=GREY)
        return
    untracked = [w.label for w in r.healing if w not in tracked]
    for wound in tracked:
        _wound_healing(pdf, wound, several=len(r.healing) > 1)
    if untracked:
        pdf.para(f"No measured visit yet of: {', '.join(untracked)}.", colour=GREY)


def _wound_healing(pdf: ReportPDF, wound: WoundHealing, several: bool) -> None:
    track = wound.track
    pdf.add_page()
    pdf.heading(f"Healing over time — {wound.label}" if several else "Healing over time", new_page_if_below=0)
    if wound.share is not None:
        pdf.facts(share_facts(wound.share))
    area, relief, volume = healing_series(track)
    width, height = pdf.epw, 52
    y = pdf.get_y()
    plot = {"points": area.points, "title": area.title, "y_label": area.unit}
    line_plot(pdf, pdf.l_margin, y, width, height, **plot, fit=area.fit, marks=area.all_marks())
    half = (width - 6) / 2
    for i, series in enumerate((relief, volume)):
        x = pdf.l_margin + i * (half + 6)
        line_plot(pdf, x, y + height + 6, half, 46, points=series.points, title=series.title, y_label=series.unit)
    pdf.set_y(y + height + 56)
    rows = [
        [
            f"{s.day:g}",
            s.status,
            figure(s.area_cm2, "area_cm2"),
            figure(s.relief_max_mm, "relief_max_mm"),
            figure(s.volume_cm3, "volume_cm3"),
            f"{s.percent_area_reduction:.1f} %" if s.percent_area_reduction is not None else "—",
            s.confidence_level or "—",
        ]
        for s in track.sessions
    ]
    pdf.table(
        ["Day", "Status", "Area", "Relief", "Volume", "Area reduction", "Confidence"],
        rows,
        [16, 22, 30, 28, 30, 32, 24],
    )
    rate = track.healing_rate_cm2_per_day
    closure = track.projected_closure_day
    span = track.projected_closure_range_days
    facts = [("Healing rate", figure(rate, "healing_rate_cm2_per_day", "cm²/day") + " (least-squares slope)")]
    if closure is not None:
        low = "?" if not span or span[0] is None else f"{span[0]:.0f}"
        high = "open" if not span or span[1] is None else f"{span[1]:.0f}"
        facts.append(
            (
                "Projected closure",
                f"day {figure(closure, 'closure_day', '')} (95 % range {low} to {high}); "
                "an extrapolation of the line, not a prediction of healing",
            )
        )
    elif track.projection_note:
        facts.append(("Projected closure", track.projection_note))
    pdf.facts(facts)
    pdf.subheading("Review prompts")
    for flag in track.stall_flags:
        state = "MET — review" if flag.triggered else "not met" if flag.evaluable else "not yet evaluable"
        pdf.para(
            f"{flag.rule}: {state}. {flag.detail}", bold=flag.triggered, colour=URGENT if flag.triggered else (0, 0, 0)
        )
        pdf.para(flag.citation, size=7, colour=GREY, indent=3)
    pdf.bullets(track.notes, colour=GREY)
    pdf.para(track.disclaimer, size=7.5, colour=GREY)


def share_facts(share: BodyShare) -> list[tuple[str, str]]:
    """The wound's measured share of the body beside the chart's, each with its source."""
    measured = (
        f"{share.measured_percent:.3f} %TBSA ({figure(share.measured_area_cm2, 'area_cm2')} on day "
        f"{share.measured_day:.0f}; {SHARE_SOURCES['measured']})"
        if share.measured_percent is not None
        else "not computed: the patient's height or weight is not recorded"
    )
    charted = (
        f"{share.charted_percent:.3f} %TBSA of the wound's regions ({share.regions_percent:.3f} %TBSA in all); "
        f"{SHARE_SOURCES['charted']}; {share.charted_by}"
        if share.charted_percent is not None and share.regions_percent is not None
        else "no burn chart (with the patient's age) to compare with"
    )
    rows = [("Share measured in 3D", measured), ("Share on the burn chart", charted)]
    if share.flag:
        rows.append(("Check", share.flag))
    return rows
