"""What a clinic sends for an encounter: its record, its finished analyses with the files that matter, and a
summary for the consultant's case list, read in one snapshot of the gateway's database."""

from __future__ import annotations

import sqlite3
from dataclasses import dataclass, field

import msgspec

from base import folders
from base.folders import media_root
from base.storage import assets as asset_rows
from base.storage import records as store
from base.storage.blobs import MediaStore
from schemas.base import iso, utcnow
from schemas.clinical_results import Assessment, ReferralTier
from schemas.config import Config
from schemas.jobs import BurnAnalysis
from schemas.patient import Encounter
from schemas.records import ENCOUNTER_PARTS, EncounterRecord, Record, RecordKind
from schemas.transfer import BundleManifest, CaseSummary, CaseWound, Urgency
from schemas.wound import Wound
from sync.bundle import PartData

ANALYSIS_FILES = (
    "analysis.json",
    "metrics/metrics.json",
    "surface/burn_surface.glb",
    "segmentation/overlays/*.jpg",
    "report.pdf",
)
"""Per analysis: the result, the burn painted on the mesh (GLB), the overlays that show the burn on each picture,
and the PDF report when there is one."""


@dataclass(frozen=True)
class Snapshot:
    record: EncounterRecord
    analyses: list[Record]
    """The encounter's finished analyses (`burn_analysis` records)."""
    parts: list[PartData]
    wounds: list[Record] = field(default_factory=list)
    """The patient's live wounds (`wound` records), oldest first."""


def snapshot(conn: sqlite3.Connection, config: Config, encounter_id: str, extra: tuple[PartData, ...] = ()) -> Snapshot:
    """The encounter's record and every part to send (record, patient, the patient's wounds, analyses with their
    files, photos), and `extra` (the clinical report, report.pdf; the wounds' healing, healing.json)."""
    encounter = store.get_head(conn, RecordKind.encounter, encounter_id)
    record = EncounterRecord(encounter=encounter, parts=store.heads_of_children(conn, encounter_id, ENCOUNTER_PARTS))
    patient_id = _encounter(encounter).patient_id
    patient = store.get_head(conn, RecordKind.patient, patient_id)
    wounds = [
        w for w in store.list_heads(conn, RecordKind.wound, parent_id=patient_id, limit=None) if not w.meta.deleted
    ]
    parts = [
        PartData("record.json", msgspec.json.encode(record)),
        PartData("patient.json", msgspec.json.encode(patient)),
        PartData("wounds.json", msgspec.json.encode(wounds)),
    ]
    analyses = store.list_heads(conn, RecordKind.burn_analysis, parent_id=encounter_id, limit=None)
    for analysis in analyses:
        job_id = analysis.meta.id
        parts.append(PartData(f"analyses/{job_id}/record.json", msgspec.json.encode(analysis)))
        folder = folders.analysis_dir(config, job_id)
        for name in folders.matching_files(folder, ANALYSIS_FILES):
            parts.append(PartData(f"analyses/{job_id}/{name}", (folder / name).read_bytes()))
    parts += _pictures(conn, MediaStore(media_root(config)), encounter_id, config.sync.pictures)
    parts += extra
    return Snapshot(record=record, analyses=analyses, parts=parts, wounds=wounds)


def summarize(snap: Snapshot) -> CaseSummary:
    """Urgency from the referral assessment computed at the clinic, and the headline figures."""
    assessment_record = snap.record.parts.get(RecordKind.assessment)
    assessment = msgspec.convert(assessment_record.data, Assessment) if assessment_record else None
    urgency, reasons = _urgency(assessment)
    analyses = sorted((msgspec.convert(a.data, BurnAnalysis) for a in snap.analyses), key=lambda a: a.completed_at)
    latest = _latest_scaled(analyses)
    return CaseSummary(
        urgency=urgency,
        urgency_reasons=reasons,
        encounter_mode=_encounter(snap.record.encounter).mode.value,
        age_years=assessment.age_years if assessment else None,
        tbsa_percent=assessment.tbsa.tbsa_percent if assessment and assessment.tbsa else None,
        analyses=len(analyses),
        area_cm2=latest.result.metrics.area_cm2 if latest else None,
        analysis_confidence=latest.result.confidence.level if latest and latest.result.confidence else None,
        wounds=_case_wounds(snap.wounds, analyses),
    )


def manifest_for(
    snap: Snapshot, *, bundle_id: str, site_id: str, version: int, supersedes: str | None, created_by: str
) -> BundleManifest:
    encounter = snap.record.encounter
    return BundleManifest(
        bundle_id=bundle_id,
        site_id=site_id,
        patient_id=_encounter(encounter).patient_id,
        encounter_id=encounter.meta.id,
        version=version,
        supersedes=supersedes,
        created_at=iso(utcnow()),
        created_by=created_by,
        summary=summarize(snap),
        parts=[p.described for p in snap.parts],
    )


def _encounter(record: Record) -> Encounter:
    return msgspec.convert(record.data, Encounter)


def _latest_scaled(analyses: list[BurnAnalysis]) -> BurnAnalysis | None:
    """The last of `analyses` (oldest first) measured with a metric scale."""
    scaled = [a for a in analyses if a.result.metrics.area_cm2 is not None]
    return scaled[-1] if scaled else None


def _case_wounds(wounds: list[Record], analyses: list[BurnAnalysis]) -> list[CaseWound]:
    """Each wound with this encounter's analyses of it (oldest first); an analysis of no wound is the wound's when
    the patient has only one (the gateway's job row holds the rest, which sync does not read)."""
    only = wounds[0].meta.id if len(wounds) == 1 else None
    shown = []
    for record in wounds:
        wound = msgspec.convert(record.data, Wound)
        own = [a for a in analyses if (a.wound_id or only) == wound.id]
        latest = _latest_scaled(own)
        shown.append(
            CaseWound(
                wound_id=wound.id,
                label=wound.label,
                regions=[r.value for r in wound.regions],
                state=wound.state.value,
                analyses=len(own),
                area_cm2=latest.result.metrics.area_cm2 if latest else None,
            )
        )
    return shown


def _urgency(assessment: Assessment | None) -> tuple[Urgency, list[str]]:
    if assessment is None or assessment.referral is None:
        return Urgency.undetermined, ["no referral assessment yet (burn chart or patient data missing)"]
    criteria = assessment.referral.current.criteria
    met = [c for c in criteria if c.met]
    if any(c.tier is ReferralTier.immediate for c in met):
        return Urgency.immediate, [c.text for c in met]
    if met:
        return Urgency.consult, [c.text for c in met]
    if any(c.met is None for c in criteria):
        return Urgency.undetermined, [f"undetermined: {c.text}" for c in criteria if c.met is None]
    return Urgency.routine, []


def _pictures(conn: sqlite3.Connection, media: MediaStore, encounter_id: str, limit: int) -> list[PartData]:
    """The encounter's photos in the order they were taken in (up to `limit`; overlays show analysed ones too)."""
    suffixes = {"image/jpeg": ".jpg", "image/png": ".png", "image/heic": ".heic"}
    return [
        PartData(f"photos/{p.id}{suffixes.get(p.media_type, '')}", media.blob(p.sha256).read_bytes())
        for p in asset_rows.encounter_photos(conn, encounter_id, limit)
        if media.blob(p.sha256).exists()
    ]
