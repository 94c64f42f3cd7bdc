"""What an encounter opens on: a short summary a nurse reads in the first screen of a phone. Urgent
recommendations first, then %TBSA, the fluids now, the referral, the latest 3D measurement and what the record
still lacks, each one tap from its page. Made from the same reading as the rest of the overview (EncounterView)."""

from __future__ import annotations

from dataclasses import dataclass, field

from base.web.pages.fluid_card import fluid_card
from base.web.pages.referral_card import referral_card
from gateway.pages.encounter_view import PART_PAGES, PART_TITLES, EncounterView
from schemas.analysis import AnalysisStatus
from schemas.records import RecordKind

MEASURED = "Last 3D measurement"


@dataclass(frozen=True)
class SummaryLine:
    label: str
    value: str
    href: str
    """The page (or the place on this page) that holds the detail."""


@dataclass(frozen=True)
class EncounterSummary:
    urgent: list[tuple[str, str]] = field(default_factory=list)
    """(anchor on the overview, text) of each urgent recommendation still pending, in the order shown below."""
    lines: list[SummaryLine] = field(default_factory=list)
    missing: list[SummaryLine] = field(default_factory=list)
    """The record parts not recorded yet, each with its form."""


def _urgent(view: EncounterView) -> list[tuple[str, str]]:
    support = view.decision_support
    if support is None:
        return []
    ordered = sorted(support.recommendations, key=lambda r: not r.urgent)  # as recommendations.html numbers them
    return [(f"#rec-{i}", r.text) for i, r in enumerate(ordered, start=1) if r.urgent and r.state.value == "pending"]


def _measurement(view: EncounterView, base: str) -> SummaryLine:
    visits = view.snapshot.encounter_analyses or view.snapshot.analyses
    if not visits:
        return SummaryLine(MEASURED, "None yet: take the photos", f"{base}/pictures")
    visit = visits[-1]
    analysis = visit.analysis.value
    result, job = analysis.result, analysis.job_id
    wound = f"{visit.wound}: " if visit.wound else ""
    if result.status is AnalysisStatus.failed:
        value = f"{wound}no measurement, the analysis failed"
    elif result.metrics.area_cm2 is None:
        value = f"{wound}no size in cm (no scale in the photos)"
    else:
        level = f", confidence {result.confidence.level}" if result.confidence else ""
        value = f"{wound}{result.metrics.area_cm2:.1f} cm²{level}"
    return SummaryLine(MEASURED, value, f"/analyses/{job}")


def _advice(view: EncounterView, new: int) -> list[SummaryLine]:
    notes = view.consultations
    if not notes:
        return []
    latest = notes[-1].note
    fresh = f"{new} new: " if new else ""
    return [
        SummaryLine("Burn center advice", f"{fresh}{latest.recommendation.value.replace('_', ' ')}", "#burn-center")
    ]


def encounter_summary(view: EncounterView, new_advice: int = 0) -> EncounterSummary:
    base = f"/encounters/{view.encounter.meta.id}"
    assessment = view.assessment
    tbsa = assessment.tbsa if assessment else None
    lines = [
        SummaryLine(
            "Burned area",
            f"{tbsa.tbsa_percent:.1f} %TBSA ({tbsa.method})" if tbsa else "Not charted yet",
            f"{base}/burn-chart",
        ),
        SummaryLine("Fluids now", fluid_card(assessment).value if assessment else "—", "#assessment"),
        SummaryLine("Referral", referral_card(assessment).value, "#assessment"),
        *_advice(view, new_advice),
        _measurement(view, base),
    ]
    recorded = view.parts
    missing = [
        SummaryLine(PART_TITLES[kind], "not recorded", f"{base}/parts/{slug}")
        for slug, kind in PART_PAGES.items()
        if kind not in recorded
    ]
    if RecordKind.burn_chart not in recorded:
        missing.insert(0, SummaryLine(PART_TITLES[RecordKind.burn_chart], "not recorded", f"{base}/burn-chart"))
    return EncounterSummary(urgent=_urgent(view), lines=lines, missing=missing)
