"""The DICOM export of an encounter (docs/dicom.md): the record snapshot the clinical report is made from, that
report, the photos the analyses used and each analysis's surface, as one study; written to a folder or sent to
the hospital's PACS over DICOMweb, each send recorded and audited (base/pacs.py)."""

from __future__ import annotations

import datetime as dt
import logging
import sqlite3
from pathlib import Path

from base import pacs
from base.accounts.permissions import Principal, require_read
from base.folders import media_root
from base.storage import assets as asset_store
from base.storage import audit, records
from base.storage.blobs import MediaStore
from gateway.documents.fhir import SURFACE, taken
from gateway.documents.reports import REPORT_KINDS, ReportService
from processing.dicom import web
from processing.dicom.inputs import Analysis, Photo, StudyInput
from processing.dicom.study import Study, build
from schemas.config import Config
from schemas.dicom import PacsSend
from schemas.encounter_snapshot import EncounterSnapshot
from schemas.errors import NotFound, PacsNotConfigured
from schemas.records import RecordKind

log = logging.getLogger(__name__)


def _who(principal: Principal | None) -> tuple[str | None, str | None]:
    return (principal.user_id, principal.device_id) if principal else (None, None)


class DicomService:
    def __init__(self, db, config: Config, reports: ReportService):
        self.db = db
        self.config = config
        self.reports = reports
        self.store = MediaStore(media_root(config))

    @property
    def configured(self) -> bool:
        return self.config.dicom.configured

    def _photos(self, conn: sqlite3.Connection, snapshot: EncounterSnapshot) -> list[Photo]:
        out: dict[str, Photo] = {}
        for visit in snapshot.encounter_analyses:
            value = visit.analysis.value
            for asset_id in value.assets:
                if asset_id in out:
                    continue
                try:
                    asset = asset_store.get_asset(conn, asset_id)
                except NotFound:
                    log.warning("analysis %s names asset %s, which is not stored: left out", value.job_id, asset_id)
                    continue
                path = self.store.blob(asset.sha256)
                if not path.is_file() or asset.media_type.is_video:
                    continue
                when = taken(asset)
                out[asset_id] = Photo(
                    asset_id=asset.id,
                    data=path.read_bytes(),
                    media_type=asset.media_type.value,
                    filename=asset.filename,
                    taken_at=dt.datetime.fromisoformat(when) if when else None,
                    camera_make=asset.metadata.camera_make or "",
                    camera_model=asset.metadata.camera_model or "",
                    wound_id=asset.wound_id or value.wound_id,
                )
        return list(out.values())

    def study(self, principal: Principal | None, encounter_id: str, made_by: str = "") -> Study:
        """The study as of now (principal None: the gateway itself, e.g. the CLI on the gateway)."""
        if principal is not None:
            for kind in (*REPORT_KINDS, RecordKind.encounter):
                require_read(principal, kind)
        snapshot = self.reports.current(encounter_id, made_by or (principal.username if principal else "gateway"))
        report = self.reports.make_from(principal, snapshot)
        with self.db.read() as conn:
            photos = self._photos(conn, snapshot)
        analyses = []
        for visit in snapshot.encounter_analyses:
            glb = visit.folder / SURFACE
            analyses.append(Analysis(visit.analysis.value, glb.read_bytes() if glb.is_file() else None))
        dicom = self.config.dicom
        inputs = StudyInput(
            patient=snapshot.patient.value,
            encounter=snapshot.encounter.value,
            wounds=[w.value for w in snapshot.wounds],
            photos=photos,
            analyses=analyses,
            report_pdf=report.pdf,
            made_at=snapshot.made_at,
            software_version=snapshot.software_version,
            institution=dicom.institution_name or self.config.report.clinic_name,
            patient_id_rule=dicom.patient_id_rule,
            patient_id_prefix=dicom.patient_id_prefix,
            issuer_of_patient_id=dicom.issuer_of_patient_id,
        )
        return build(inputs)

    def write(self, principal: Principal | None, encounter_id: str, folder: Path, made_by: str = "") -> list[Path]:
        study = self.study(principal, encounter_id, made_by)
        written = study.write(folder)
        self._audit(principal, encounter_id, "dicom.export", f"study {study.study_uid}: {len(written)} files")
        return written

    def send(self, principal: Principal | None, encounter_id: str, url: str = "", made_by: str = "") -> PacsSend:
        """Send the study to the PACS (`url`, else [dicom] endpoint); the send as recorded. A failure is recorded
        as failed, audited and raised as PacsFailed: nothing is marked as sent."""
        target = web.endpoint(self.config.dicom, url)
        study = self.study(principal, encounter_id, made_by)
        user_id, device_id = _who(principal)
        subject = pacs.Subject(
            kind=RecordKind.encounter.value,
            record_id=encounter_id,
            requested_by=made_by or (principal.username if principal else "gateway"),
            user_id=user_id,
            device_id=device_id,
        )
        return pacs.send_recorded(
            self.db, subject, target.shown, study.study_uid, len(study.instances), lambda: web.send(study, target)
        )

    def send_configured(self, principal: Principal, encounter_id: str) -> PacsSend:
        """The pages' and the API's send: only ever to [dicom] endpoint (a client never names where patient data
        goes); 409 where none is configured, after the principal's right to the record (403) is checked."""
        require_read(principal, RecordKind.encounter)
        if not self.configured:
            raise PacsNotConfigured("no PACS is configured at this gateway: set [dicom] endpoint (docs/dicom.md)")
        return self.send(principal, encounter_id)

    def sends(self, principal: Principal | None, encounter_id: str) -> list[PacsSend]:
        """The encounter's sends, newest first; one left "sending" by a stopped gateway reads as failed."""
        if principal is not None:
            require_read(principal, RecordKind.encounter)
        with self.db.read() as conn:
            records.get_head(conn, RecordKind.encounter, encounter_id)
        return pacs.sends_of(self.db, encounter_id)

    def _audit(self, principal: Principal | None, encounter_id: str, action: str, detail: str) -> None:
        user_id, device_id = _who(principal)
        with self.db.write() as conn:
            audit.append(
                conn,
                action=action,
                user_id=user_id,
                device_id=device_id,
                kind=RecordKind.encounter.value,
                record_id=encounter_id,
                detail=detail,
            )
