"""The clinical report of one encounter, as a PDF (fpdf2): pure in its inputs, bytes out.

    render(inputs) -> bytes

Sections in order: who and when, at a glance, allergies, medications, tetanus and the rest of the history,
primary and secondary survey with the mechanism, the burn chart with %TBSA,
fluids at the time the report is made, referral, each measured visit, healing over time, decision support,
the burn center's advice. Every page carries the decision-support notice, page n of N, the report id and the
SHA-256 over the record versions it was made from. What the record lacks is said, never filled in.
"""

from __future__ import annotations

from pathlib import Path

from processing.report import sections_advice, sections_analysis, sections_header, sections_healing, sections_record
from processing.report.inputs import versions_digest
from processing.report.layout import ReportPDF
from schemas.encounter_snapshot import EncounterSnapshot


def missing_lines(r: EncounterSnapshot) -> list[str]:
    lines = list(r.assessment.value.missing) if r.assessment else ["calculator results (nothing recorded yet)"]
    if r.assessment:
        lines += r.assessment.value.calculator_errors
    if not r.analyses:
        lines.append("3D analysis: no finished analysis of the burn")
    return lines


def render(r: EncounterSnapshot) -> bytes:
    pdf = ReportPDF(r.report_id, versions_digest(r.refs()))
    pdf.set_title(f"Burn assessment report {r.report_id}")
    pdf.set_author(r.made_by)
    pdf.set_creator(f"burnedge {r.software_version}")
    pdf.set_creation_date(r.made_at)
    pdf.add_page()
    sections_header.header(pdf, r, missing_lines(r))
    sections_header.at_a_glance(pdf, r)
    sections_header.history(pdf, r)
    sections_record.surveys(pdf, r)
    sections_record.burn_chart(pdf, r)  # on a new page unless the drawing fits below the surveys
    sections_record.fluids(pdf, r)
    sections_record.referral(pdf, r)
    with sections_analysis.scratch_dir() as scratch:
        sections_analysis.analyses(pdf, r, Path(scratch))
        sections_healing.healing(pdf, r)
        sections_advice.decision_support(pdf, r)
        sections_advice.consultations(pdf, r)
        return bytes(pdf.output())
