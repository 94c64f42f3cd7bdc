"""What handlers get injected: the services and the authenticated principal."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Annotated

from litestar import Request
from litestar.params import Dependency

from base.accounts.permissions import Principal
from base.accounts.service import AccountService
from base.folders import media_root
from base.storage.blobs import MediaStore
from gateway.analyses.service import AnalysisService
from gateway.capture.assets import AssetService
from gateway.capture.frames import FrameService
from gateway.capture.thumbnails import ThumbnailService
from gateway.capture.uploads import UploadService
from gateway.documents.dicom import DicomService
from gateway.documents.fhir import FhirService
from gateway.documents.reports import ReportService
from gateway.phones.sync import PhoneSync
from gateway.records import audit_trail
from gateway.records.decision_support import DecisionSupportService
from gateway.records.service import RecordService
from gateway.storage.database import Database
from gateway.transfers.service import TransferService
from gateway.wounds import CHECKS as WOUND_CHECKS
from gateway.wounds.service import WoundService
from schemas.audit import AuditVerification
from schemas.config import Config


@dataclass
class Services:
    config: Config
    db: Database
    accounts: AccountService
    records: RecordService
    decision_support: DecisionSupportService
    phone_sync: PhoneSync
    assets: AssetService
    uploads: UploadService
    frames: FrameService
    analyses: AnalysisService
    transfers: TransferService
    reports: ReportService
    fhir: FhirService
    dicom: DicomService
    thumbnails: ThumbnailService
    wounds: WoundService
    run_sync_now: Callable[[], None] = lambda: None
    """Starts a sync round at once if the link is on (set by the scheduler)."""

    def verify_audit(self, principal: Principal | None) -> AuditVerification:
        return audit_trail.verify(self.db, principal, self.config)

    @classmethod
    def build(cls, config: Config, db: Database) -> Services:
        records = RecordService(db, config, WOUND_CHECKS)
        reports = ReportService(db, config)
        store = MediaStore(media_root(config))
        assets = AssetService(db, config, store)
        return cls(
            config=config,
            db=db,
            accounts=AccountService(db, config.security),
            records=records,
            decision_support=DecisionSupportService(db, config),
            phone_sync=PhoneSync(records, config.gateway.page_max),
            assets=assets,
            uploads=UploadService(db, config, store, assets),
            frames=FrameService(db, config, assets),
            analyses=AnalysisService(db, config, assets),
            transfers=TransferService(db, config, reports),
            reports=reports,
            fhir=FhirService(db, config, reports),
            dicom=DicomService(db, config, reports),
            thumbnails=ThumbnailService(config, assets),
            wounds=WoundService(records),
        )


def provide_services(request: Request) -> Services:
    return request.app.state.services


ServicesDep = Annotated[Services, Dependency(skip_validation=True)]
"""Declared by name ("services"); the app factory provides it. Not validated: it is the app's own object."""
