"""The clinic's record as the case page shows it, read from the bundle's record.json: the history with allergies,
medications and tetanus, ABCDE, the secondary survey and mechanism, the burn chart, and every decision-support
recommendation, urgent first. The words are the report's (processing/report/history_text.py, record_text.py), so
the consultant reads what the clinic printed.

A bundle from an older clinic version still shows: a part it did not send, or a field of a part its version did
not have, is named as "not sent by this clinic's version", never shown as a default value.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TypeVar

import msgspec
from markupsafe import Markup

from base.web.pages.rendering import svg
from processing.report.body_geometry import DEPTH_LEGEND
from processing.report.history_text import allergy_lines, history_facts, medication_lines, tetanus_lines
from processing.report.record_text import mechanism_text, primary_facts, secondary_lines, urgent_first, words
from processing.views.body_chart_svg import REGION_LABELS, body_chart_svg, chart_entries
from schemas.burn_chart import BurnChart
from schemas.clinical_results import Assessment
from schemas.decision_support import DecisionSupport, Recommendation
from schemas.record_parts import Intake, Mechanism, PrimarySurvey, SecondarySurvey
from schemas.records import EncounterRecord, RecordKind

T = TypeVar("T", bound=msgspec.Struct)
NOT_SENT = "not sent by this clinic's version"


@dataclass
class ChartRow:
    region: str
    depth: str
    share: str
    tbsa: str


@dataclass
class RecordView:
    history: list[tuple[str, list[str]]]
    """Allergies, current medications, tetanus history, then the rest of the intake: label and lines."""
    intake_recorded: bool
    primary: list[tuple[str, str]] | None
    secondary: list[str] | None
    secondary_notes: str
    mechanism: str | None
    mechanism_description: str
    chart_svg: Markup | None
    """The body chart drawn by processing/views (every text escaped there)."""
    chart_rows: list[ChartRow]
    special_areas: list[str]
    recommendations: list[Recommendation] | None
    """Urgent first; None when the bundle holds no decision support."""
    support_missing: list[str] = field(default_factory=list)
    support_sent: bool = True
    not_sent: list[str] = field(default_factory=list)
    """Fields of a part that the clinic's version did not send, as "intake: tetanus doses"."""
    unreadable: list[str] = field(default_factory=list)
    """Parts this center's version could not read, with why."""


class _Reader:
    def __init__(self, record: EncounterRecord):
        self.record = record
        self.not_sent: list[str] = []
        self.unreadable: list[str] = []

    def part(self, kind: RecordKind, struct: type[T]) -> T | None:
        stored = self.record.parts.get(kind)
        if stored is None or stored.meta.deleted:
            return None
        try:
            value = msgspec.convert(stored.data, struct)
        except msgspec.ValidationError as exc:
            self.unreadable.append(f"{kind.label}: this center's version could not read it ({exc})")
            return None
        absent = [name for name in struct.__struct_fields__ if name not in stored.data]
        self.not_sent += [f"{kind.label}: {words(name)}" for name in absent]
        return value


def _chart_rows(chart: BurnChart, assessment: Assessment | None) -> list[ChartRow]:
    """Each charted region with its depth, the share of it burned and its %TBSA (Lund-Browder) when computed."""
    tbsa = assessment.tbsa if assessment else None
    if tbsa is not None:
        return [
            ChartRow(REGION_LABELS[c.region], DEPTH_LEGEND[c.depth], f"{c.fraction:.0%}", f"{c.tbsa_percent:.2f} %")
            for c in tbsa.contributions
        ]
    return [ChartRow(REGION_LABELS[e.region], DEPTH_LEGEND[e.depth], f"{e.fraction:.0%}", "—") for e in chart.entries]


def record_view(record: EncounterRecord, assessment: Assessment | None) -> RecordView:
    read = _Reader(record)
    intake = read.part(RecordKind.intake, Intake)
    primary = read.part(RecordKind.primary_survey, PrimarySurvey)
    secondary = read.part(RecordKind.secondary_survey, SecondarySurvey)
    mechanism = read.part(RecordKind.mechanism, Mechanism)
    chart = read.part(RecordKind.burn_chart, BurnChart)
    support = read.part(RecordKind.decision_support, DecisionSupport)
    history = [
        ("Allergies", allergy_lines(intake)),
        ("Current medications", medication_lines(intake)),
        ("Tetanus history", tetanus_lines(intake)),
    ]
    history += [(label, [value or "not recorded"]) for label, value in history_facts(intake)]
    return RecordView(
        history=history,
        intake_recorded=intake is not None,
        primary=primary_facts(primary) if primary else None,
        secondary=secondary_lines(secondary) if secondary else None,
        secondary_notes=secondary.notes if secondary else "",
        mechanism=mechanism_text(mechanism) if mechanism else None,
        mechanism_description=mechanism.description if mechanism else "",
        chart_svg=svg(body_chart_svg(chart_entries(chart.entries), title="Burn chart from the clinic"))
        if chart
        else None,
        chart_rows=_chart_rows(chart, assessment) if chart else [],
        special_areas=[f"{words(a.area)} ({DEPTH_LEGEND[a.depth]})" for a in chart.special_areas] if chart else [],
        recommendations=urgent_first(support.recommendations) if support else None,
        support_missing=support.missing if support else [],
        support_sent=RecordKind.decision_support in record.parts,
        not_sent=read.not_sent,
        unreadable=read.unreadable,
    )
