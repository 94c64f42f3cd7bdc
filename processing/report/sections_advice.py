"""Decision support with each recommendation's source and state, and the burn center's advice."""

from __future__ import annotations

from processing.report.figures import clock
from processing.report.layout import GREY, URGENT, ReportPDF
from processing.report.record_text import urgent_first
from schemas.decision_support import RecommendationState
from schemas.encounter_snapshot import EncounterSnapshot

STATE_WORDS = {
    RecommendationState.pending: "PENDING — not yet confirmed by a clinician",
    RecommendationState.accepted: "accepted",
    RecommendationState.declined: "declined",
}


def decision_support(pdf: ReportPDF, r: EncounterSnapshot) -> None:
    pdf.heading("Decision support", new_page_if_below=90)
    record = r.decision_support
    if record is None:
        pdf.para("No recommendations computed for this encounter.", colour=GREY)
        return
    support = record.value
    pdf.para(f"{support.notice} Judged at {clock(support.as_of)}.", colour=GREY)
    for rec in urgent_first(support.recommendations):
        if pdf.get_y() > pdf.h - 60:
            pdf.add_page()
        label = rec.category.label.capitalize() + (" — URGENT" if rec.urgent else "")
        pdf.subheading(label)
        pdf.para(rec.text, colour=URGENT if rec.urgent else (0, 0, 0))
        pdf.bullets(rec.details, size=8)
        state = STATE_WORDS[rec.state]
        if rec.state is not RecommendationState.pending:
            state += f" by {rec.decided_by} at {clock(rec.decided_at)}"
            if rec.reason:
                state += f": “{rec.reason}”"
        pdf.para(f"State: {state}", bold=rec.state is RecommendationState.pending, size=8)
        when = f" ({rec.source.year})" if rec.source.year else f" (web page read {rec.source.accessed})"
        source = f"{rec.source.guideline}{when}, {rec.source.section}" + (
            f" <{rec.source.url}>" if rec.source.url else ""
        )
        pdf.para(f"Source: {source}", size=7, colour=GREY)
        used = "; ".join(f"{i.name} = {i.value} ({i.kind} v{i.version})" for i in rec.inputs)
        if used:
            pdf.para(f"Inputs: {used}", size=7, colour=GREY)
    if support.missing:
        pdf.subheading("Rules that could not be fully applied")
        pdf.bullets(support.missing, colour=GREY, size=8)


def consultations(pdf: ReportPDF, r: EncounterSnapshot) -> None:
    pdf.heading("Advice from the burn center", new_page_if_below=40)
    if not r.consultations:
        pdf.para("No advice received from a burn center for this encounter.", colour=GREY)
        return
    for item in r.consultations:
        c = item.value
        note = c.note
        pdf.subheading(f"{note.consultant} ({note.center_id}) — {note.recommendation.value.replace('_', ' ')}")
        pdf.para(
            f"Written {note.written_at}; received {c.received_at}; about case version {note.bundle_version}.",
            colour=GREY,
            size=8,
        )
        pdf.para(note.advice)
        pdf.para(note.notice, colour=GREY, size=7.5)
