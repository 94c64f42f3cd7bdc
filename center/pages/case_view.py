"""What the case page shows, read from the bundle the clinic sent: the record (record_view.py: history, ABCDE,
mechanism, the burn chart, decision support), the patient, its wounds (wound_view.py), each analysis with its
painted surface, the photos and the report."""

from __future__ import annotations

from dataclasses import dataclass, field

import msgspec

from base.web.pages.rendering import patient_name
from center.pages.record_view import RecordView, record_view
from center.pages.wound_view import HEALING_PART, WOUNDS_PART, WoundsView, wounds_view
from schemas.central import CaseDetail
from schemas.clinical_results import Assessment
from schemas.jobs import BurnAnalysis
from schemas.records import EncounterRecord, Record, RecordKind

PAINTED_SURFACE = "surface/burn_surface.glb"


@dataclass
class AnalysisView:
    analysis: BurnAnalysis
    surface_part: str | None
    overlay_parts: list[str] = field(default_factory=list)


@dataclass
class CaseView:
    detail: CaseDetail
    record: EncounterRecord
    patient: Record
    assessment: Assessment | None
    clinic_record: RecordView
    analyses: list[AnalysisView]
    photo_parts: list[str]
    report_part: str | None
    wounds: WoundsView | None = None
    """None for a bundle sent before wounds were kept."""

    @property
    def patient_name(self) -> str:
        return patient_name(self.patient.data)


def case_view(services, who, site_id: str, bundle_id: str) -> CaseView:
    detail = services.cases.case(who, site_id, bundle_id)
    names = [p.name for p in detail.manifest.parts]

    def part(name: str) -> bytes:
        return services.cases.part(who, site_id, bundle_id, name)[0]

    record = msgspec.json.decode(part("record.json"), type=EncounterRecord)
    patient = msgspec.json.decode(part("patient.json"), type=Record)
    assessment_record = record.parts.get(RecordKind.assessment)
    assessment = msgspec.convert(assessment_record.data, Assessment) if assessment_record else None
    analyses = []
    for name in names:
        if name.startswith("analyses/") and name.endswith("/record.json") and name.count("/") == 2:
            analysis = msgspec.convert(msgspec.json.decode(part(name))["data"], BurnAnalysis)
            prefix = name.rsplit("/", 1)[0] + "/"
            surface = prefix + PAINTED_SURFACE
            analyses.append(
                AnalysisView(
                    analysis=analysis,
                    surface_part=surface if surface in names else None,
                    overlay_parts=[n for n in names if n.startswith(prefix + "segmentation/overlays/")],
                )
            )
    analyses.sort(key=lambda a: a.analysis.completed_at, reverse=True)
    return CaseView(
        detail=detail,
        record=record,
        patient=patient,
        assessment=assessment,
        clinic_record=record_view(record, assessment),
        analyses=analyses,
        photo_parts=[n for n in names if n.startswith("photos/")],
        report_part="report.pdf" if "report.pdf" in names else None,
        wounds=wounds_view(
            detail.manifest.summary, part(WOUNDS_PART), part(HEALING_PART) if HEALING_PART in names else None
        )
        if WOUNDS_PART in names
        else None,
    )
