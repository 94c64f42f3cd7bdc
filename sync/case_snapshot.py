"""What a clinic sends for an encounter: its record, its finished analyses with the files that matter, and a
summary for the consultant's case list, read in one snapshot of the gateway's database."""

from __future__ import annotations

import sqlite3
from dataclasses import dataclass

import msgspec

from base import folders
from base.folders import media_root
from base.storage import assets as asset_rows
from base.storage import records as store
from base.storage.blobs import MediaStore
from schemas.base import iso, utcnow
from schemas.clinical_results import Assessment, ReferralTier
from schemas.config import Config
from schemas.records import ENCOUNTER_PARTS, EncounterRecord, Record, RecordKind
from schemas.transfer import BundleManifest, CaseSummary, Urgency
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


def snapshot(conn: sqlite3.Connection, config: Config, encounter_id: str, extra: tuple[PartData, ...] = ()) -> Snapshot:
    """The encounter's record and every part to send (record, patient, analyses with their files, photos), and
    `extra` (the clinical report, report.pdf)."""
    encounter = store.get_head(conn, RecordKind.encounter, encounter_id)
    record = EncounterRecord(encounter=encounter, parts=store.heads_of_children(conn, encounter_id, ENCOUNTER_PARTS))
    patient = store.get_head(conn, RecordKind.patient, encounter.data["patient_id"])
    parts = [
        PartData("record.json", msgspec.json.encode(record)),
        PartData("patient.json", msgspec.json.encode(patient)),
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
    return Snapshot(record=record, analyses=analyses, parts=parts)


def summarize(snap: Snapshot) -> CaseSummary:
    """Urgency from the referral assessment computed at the clinic, and the headline figures."""
    assessment_record = snap.record.parts.get(RecordKind.assessment)
    assessment = msgspec.convert(assessment_record.data, Assessment) if assessment_record else None
    urgency, reasons = _urgency(assessment)
    results = [a.data["result"] for a in sorted(snap.analyses, key=lambda a: a.data["completed_at"])]
    scaled = [r for r in results if r["metrics"].get("area_cm2") is not None]
    latest = scaled[-1] if scaled else None
    return CaseSummary(
        urgency=urgency,
        urgency_reasons=reasons,
        encounter_mode=snap.record.encounter.data["mode"],
        age_years=assessment.age_years if assessment else None,
        tbsa_percent=assessment.tbsa.tbsa_percent if assessment and assessment.tbsa else None,
        analyses=len(results),
        area_cm2=latest["metrics"]["area_cm2"] if latest else None,
        analysis_confidence=(latest.get("confidence") or {}).get("level") if latest else None,
    )


def manifest_for(
    snap: Snapshot, *, bundle_id: str, site_id: str, version: int, supersedes: str | None, created_by: str
) -> BundleManifest:
    encounter = snap.record.encounter
    return BundleManifest(
        bundle_id=bundle_id,
        site_id=site_id,
        patient_id=encounter.data["patient_id"],
        encounter_id=encounter.meta.id,
        version=version,
        supersedes=supersedes,
        created_at=iso(utcnow()),
        created_by=created_by,
        summary=summarize(snap),
        parts=[p.described for p in snap.parts],
    )


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
