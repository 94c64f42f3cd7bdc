"""The FHIR R4 export of an encounter: the record snapshot the clinical report is made from, the report itself,
and the files of each analysis (photos, painted surface), as one validated Bundle."""

from __future__ import annotations

import datetime as dt
import logging
import re
import sqlite3
from pathlib import Path

import msgspec

from base.accounts.permissions import Principal, require_read
from base.folders import analysis_dir, media_root
from base.storage import assets as asset_store
from base.storage import audit
from base.storage.blobs import MediaStore
from gateway.documents.reports import REPORT_KINDS, ReportService
from processing.fhir import bundle as fhir_bundle
from processing.fhir.wound import Attached, attached
from schemas.analysis import SegmentationRecord
from schemas.capture import Asset
from schemas.config import Config
from schemas.encounter_snapshot import AnalysisVisit
from schemas.errors import NotFound
from schemas.records import RecordKind

log = logging.getLogger(__name__)
SURFACE = "surface/burn_surface.glb"
OFFSET = re.compile(r"[+-](0\d|1[0-4]):[0-5]\d")


def taken(asset: Asset) -> str | None:
    """When the camera says the photo was taken, as FHIR dateTime; None without a time zone (EXIF's own
    DateTimeOriginal has none) or in a form not understood."""
    meta = asset.metadata
    if not meta.captured_at or not meta.captured_offset or not OFFSET.fullmatch(meta.captured_offset):
        return None
    for form in ("%Y:%m:%d %H:%M:%S", "%Y-%m-%dT%H:%M:%S", "%Y-%m-%d %H:%M:%S"):
        try:
            moment = dt.datetime.strptime(meta.captured_at[:19], form)
        except ValueError:
            continue
        return moment.isoformat() + meta.captured_offset
    return None


def _photo(path: Path, asset: Asset) -> Attached:
    return attached(path, f"/api/v1/assets/{asset.id}/file", asset.media_type.value, asset.filename, taken(asset))


class FhirService:
    def __init__(self, db, config: Config, reports: ReportService):
        self.db = db
        self.config = config
        self.reports = reports
        self.store = MediaStore(media_root(config))

    def _analysis_files(self, conn: sqlite3.Connection, page: AnalysisVisit) -> fhir_bundle.AnalysisFiles:
        value = page.analysis.value
        photos = []
        for asset_id in value.assets:
            try:
                asset = asset_store.get_asset(conn, asset_id)
            except NotFound:
                log.warning("analysis %s names asset %s, which is not stored: left out", value.job_id, asset_id)
                continue
            path = self.store.blob(asset.sha256)
            if path.is_file():
                photos.append(_photo(path, asset))
        folder = analysis_dir(self.config, value.job_id)
        surface = folder / SURFACE
        url = f"/api/v1/analyses/{value.job_id}/artifacts/{SURFACE}"
        glb = attached(surface, url, "model/gltf-binary", "burn_surface.glb") if surface.is_file() else None
        segmentation = folder / "segmentation" / "segmentation.json"
        model = None
        if segmentation.is_file():
            model = msgspec.json.decode(segmentation.read_bytes(), type=SegmentationRecord).model
        return fhir_bundle.AnalysisFiles(photos=photos, surface=glb, model=model)

    def export(self, principal: Principal | None, encounter_id: str, made_by: str = "") -> dict:
        """The Bundle as of now (principal None: the gateway itself, e.g. the CLI on the gateway)."""
        if principal is not None:
            for kind in (*REPORT_KINDS, RecordKind.encounter):
                require_read(principal, kind)
        inputs = self.reports.current(encounter_id, made_by or (principal.username if principal else "gateway"))
        report = self.reports.make_from(principal, inputs)  # the same snapshot as the Bundle
        with self.db.read() as conn:
            files = fhir_bundle.BundleFiles(
                analyses={p.analysis.value.job_id: self._analysis_files(conn, p) for p in inputs.analyses},
                report=attached(
                    report.path, f"/api/v1/encounters/{encounter_id}/report.pdf", "application/pdf", "report.pdf"
                ),
            )
        try:
            out = fhir_bundle.build(inputs, files)
        except fhir_bundle.InvalidFhir as exc:
            log.error("FHIR export of encounter %s: %s", encounter_id, exc)
            raise fhir_bundle.InvalidFhir(
                "the FHIR Bundle made of this encounter did not validate: a fault in burnedge, not in the record; "
                "nothing was sent (the gateway's log names the resource)"
            ) from exc
        with self.db.write() as conn:
            audit.append(
                conn,
                action="fhir.export",
                user_id=principal.user_id if principal else None,
                device_id=principal.device_id if principal else None,
                kind=RecordKind.encounter.value,
                record_id=encounter_id,
                detail=f"FHIR Bundle {inputs.report_id}: {len(out['entry'])} resources",
            )
        return out
