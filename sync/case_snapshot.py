"""What a clinic sends for an encounter: its record, its finished analyses with the files that matter, and a
summary for the consultant's case list, all from the one encounter snapshot the gateway read
(schemas/encounter_snapshot.py), the report in the bundle made from the same one."""

from __future__ import annotations

import sqlite3
from dataclasses import dataclass

import msgspec

from base import folders
from base.folders import media_root
from base.storage import assets as asset_rows
from base.storage.blobs import MediaStore
from schemas.base import iso, utcnow
from schemas.clinical_results import Assessment, ReferralTier
from schemas.config import Config
from schemas.encounter_snapshot import AnalysisVisit, EncounterSnapshot
from schemas.jobs import BurnAnalysis
from schemas.patient import display_name
from schemas.records import EncounterRecord
from schemas.transfer import BundleManifest, CaseSummary, CaseWound, Urgency
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
    encounter: EncounterSnapshot
    record: EncounterRecord
    """The encounter and its parts as stored (record.json)."""
    parts: list[PartData]


def snapshot(
    conn: sqlite3.Connection, config: Config, encounter: EncounterSnapshot, extra: tuple[PartData, ...] = ()
) -> Snapshot:
    """Every part to send of the encounter as `encounter` read it (record, patient, the patient's wounds, analyses
    with their files), its photos (read here, in `conn`) and `extra` (the clinical report, report.pdf; the wounds'
    healing, healing.json)."""
    record = EncounterRecord(
        encounter=encounter.encounter.record,
        parts={kind: part.record for kind, part in encounter.parts().items()},
    )
    parts = [
        PartData("record.json", msgspec.json.encode(record)),
        PartData("patient.json", msgspec.json.encode(encounter.patient.record)),
        PartData("wounds.json", msgspec.json.encode([w.record for w in encounter.wounds])),
    ]
    for visit in encounter.encounter_analyses:
        job_id = visit.analysis.ref.id
        parts.append(PartData(f"analyses/{job_id}/record.json", msgspec.json.encode(visit.analysis.record)))
        for name in folders.matching_files(visit.folder, ANALYSIS_FILES):
            parts.append(PartData(f"analyses/{job_id}/{name}", (visit.folder / name).read_bytes()))
    encounter_id = encounter.encounter.value.id
    parts += _pictures(conn, MediaStore(media_root(config)), encounter_id, config.sync.pictures)
    parts += extra
    return Snapshot(encounter=encounter, record=record, parts=parts)


def summarize(snap: EncounterSnapshot) -> CaseSummary:
    """Urgency from the referral assessment computed at the clinic, and the headline figures."""
    assessment = snap.assessment.value if snap.assessment else None
    urgency, reasons = _urgency(assessment)
    latest = _latest_scaled(snap.encounter_analyses)
    return CaseSummary(
        urgency=urgency,
        urgency_reasons=reasons,
        encounter_mode=snap.encounter.value.mode.value,
        age_years=assessment.age_years if assessment else None,
        tbsa_percent=assessment.tbsa.tbsa_percent if assessment and assessment.tbsa else None,
        analyses=len(snap.encounter_analyses),
        area_cm2=latest.result.metrics.area_cm2 if latest else None,
        analysis_confidence=latest.result.confidence.level if latest and latest.result.confidence else None,
        wounds=_case_wounds(snap),
        patient_name=display_name(snap.patient.record.data),
    )


def manifest_for(
    snap: Snapshot, *, bundle_id: str, site_id: str, version: int, supersedes: str | None, created_by: str
) -> BundleManifest:
    encounter = snap.encounter.encounter.value
    return BundleManifest(
        bundle_id=bundle_id,
        site_id=site_id,
        patient_id=encounter.patient_id,
        encounter_id=encounter.id,
        version=version,
        supersedes=supersedes,
        created_at=iso(utcnow()),
        created_by=created_by,
        summary=summarize(snap.encounter),
        parts=[p.described for p in snap.parts],
    )


def _latest_scaled(visits: list[AnalysisVisit]) -> BurnAnalysis | None:
    """The analysis of the last of `visits` (oldest first) measured with a metric scale; None when none was."""
    scaled = [v.analysis.value for v in visits if v.analysis.value.result.metrics.area_cm2 is not None]
    return scaled[-1] if scaled else None


def _case_wounds(snap: EncounterSnapshot) -> list[CaseWound]:
    """Each wound with this encounter's analyses of it (oldest first); an analysis of no wound is the wound's when
    the patient has only one."""
    only = snap.wounds[0].ref.id if len(snap.wounds) == 1 else None
    shown = []
    for versioned in snap.wounds:
        wound = versioned.value
        own = [v for v in snap.encounter_analyses if (v.wound_id or only) == wound.id]
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
