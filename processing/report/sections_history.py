"""The history a clinician must see before treating: allergies with their reactions, current medications with
their doses, the tetanus history; then the rest of the intake (present illness, past history, comorbidities,
social)."""

from __future__ import annotations

from processing.report.history_text import allergy_lines, history_facts, medication_lines, tetanus_lines
from processing.report.inputs import ReportInputs
from processing.report.layout import GREY, ReportPDF


def history(pdf: ReportPDF, r: ReportInputs) -> None:
    pdf.heading("History: allergies, medications, tetanus", new_page_if_below=45)
    intake = r.intake.value if r.intake else None
    if intake is None:
        pdf.para("No intake recorded: the history below is not known.", colour=GREY)
    pdf.facts(
        [
            ("Allergies", "\n".join(allergy_lines(intake))),
            ("Current medications", "\n".join(medication_lines(intake))),
            ("Tetanus history", "\n".join(tetanus_lines(intake))),
            *history_facts(intake),
        ]
    )
