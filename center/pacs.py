"""Forwarding a received case to the burn center's own hospital PACS (docs/dicom.md): the case as the clinic sent
it (its record, patient, wounds, analyses with their surfaces, photos and report) made into the same DICOM study the
clinic would make (processing/dicom), sent over DICOMweb, each send recorded and
audited as at the clinic (base/pacs.py)."""

from __future__ import annotations

import datetime as dt

import msgspec

from base import __version__, pacs
from base.accounts.permissions import Principal
from processing.dicom import web
from processing.dicom.inputs import Analysis, Photo, StudyInput
from processing.dicom.study import Study, build
from schemas.config import Config
from schemas.dicom import PacsSend
from schemas.errors import PacsNotConfigured
from schemas.jobs import BurnAnalysis
from schemas.patient import Encounter, Patient
from schemas.records import EncounterRecord, Record
from schemas.wound import Wound

SURFACE = "surface/burn_surface.glb"
MEDIA = {".jpg": "image/jpeg", ".png": "image/png", ".heic": "image/heic"}


class CenterPacsService:
    def __init__(self, db, config: Config, cases):
        self.db = db
        self.config = config
        self.cases = cases

    @property
    def configured(self) -> bool:
        return self.config.dicom.configured

    def study(self, who: Principal, site_id: str, bundle_id: str) -> Study:
        """The DICOM study of the case as received (only those who may read the case)."""
        detail = self.cases.case(who, site_id, bundle_id)
        names = [p.name for p in detail.manifest.parts]

        def part(name: str) -> bytes:
            return self.cases.part(who, site_id, bundle_id, name)[0]

        record = msgspec.json.decode(part("record.json"), type=EncounterRecord)
        patient = msgspec.json.decode(part("patient.json"), type=Record)
        wounds = msgspec.json.decode(part("wounds.json"), type=list[Record]) if "wounds.json" in names else []
        analyses = []
        for name in names:
            if name.startswith("analyses/") and name.endswith("/record.json") and name.count("/") == 2:
                stored = msgspec.json.decode(part(name), type=Record)
                surface = name.rsplit("/", 1)[0] + "/" + SURFACE
                glb = part(surface) if surface in names else None
                analyses.append(Analysis(msgspec.convert(stored.data, BurnAnalysis), glb))
        analyses.sort(key=lambda a: a.record.completed_at)
        used = {asset for a in analyses for asset in a.record.assets}
        wound_of = {asset: a.record.wound_id for a in analyses for asset in a.record.assets}
        photos = []
        for name in names:
            stem, dot, suffix = name.removeprefix("photos/").rpartition(".")
            if name.startswith("photos/") and dot and stem in used and f".{suffix}" in MEDIA:
                photos.append(Photo(stem, part(name), MEDIA[f".{suffix}"], name, wound_id=wound_of.get(stem)))
        dicom = self.config.dicom
        inputs = StudyInput(
            patient=msgspec.convert(patient.data, Patient),
            encounter=msgspec.convert(record.encounter.data, Encounter),
            wounds=[msgspec.convert(w.data, Wound) for w in wounds],
            photos=photos,
            analyses=analyses,
            report_pdf=part("report.pdf") if "report.pdf" in names else None,
            made_at=dt.datetime.fromisoformat(detail.manifest.created_at),
            software_version=__version__,
            institution=dicom.institution_name,
            patient_id_rule=dicom.patient_id_rule,
            patient_id_prefix=dicom.patient_id_prefix,
            issuer_of_patient_id=dicom.issuer_of_patient_id,
        )
        return build(inputs)

    def send(self, who: Principal, site_id: str, bundle_id: str) -> PacsSend:
        """Send the case to [dicom] endpoint; the send as recorded. A failure is recorded, audited and raised as
        PacsFailed: nothing is marked as sent. The right to read the case is checked before the configuration."""
        self.cases.case(who, site_id, bundle_id)
        if not self.configured:
            raise PacsNotConfigured("no PACS is configured at this burn center: set [dicom] endpoint (docs/dicom.md)")
        target = web.endpoint(self.config.dicom)
        study = self.study(who, site_id, bundle_id)
        subject = pacs.Subject(
            kind="case", record_id=_subject(site_id, bundle_id), requested_by=who.username, user_id=who.user_id
        )
        return pacs.send_recorded(
            self.db, subject, target.shown, study.study_uid, len(study.instances), lambda: web.send(study, target)
        )

    def sends(self, who: Principal, site_id: str, bundle_id: str) -> list[PacsSend]:
        """The case's sends, newest first (a send cut short by a stopped server reads as failed)."""
        self.cases.case(who, site_id, bundle_id)  # the same check as reading the case
        return pacs.sends_of(self.db, _subject(site_id, bundle_id))


def _subject(site_id: str, bundle_id: str) -> str:
    return f"{site_id}/{bundle_id}"
