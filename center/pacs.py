"""Forwarding a received case to the burn center's own hospital PACS (docs/dicom.md): the case as the clinic sent
it (its record, patient, wounds, analyses with their surfaces, photos and report) made into the same DICOM study the
clinic would make (processing/dicom), sent over DICOMweb, each send recorded (base/storage/pacs_sends.py) and
audited, as at the clinic."""

from __future__ import annotations

import datetime as dt

import msgspec

from base import __version__
from base.accounts.permissions import Principal
from base.storage import audit, pacs_sends
from processing.dicom import web
from processing.dicom.inputs import Analysis, Photo, StudyInput
from processing.dicom.study import Study, build
from schemas.base import iso, utcnow
from schemas.config import Config
from schemas.dicom import PacsSend, PacsSendState
from schemas.errors import PacsFailed
from schemas.ids import uuid7
from schemas.jobs import BurnAnalysis
from schemas.patient import Encounter, Patient
from schemas.records import EncounterRecord, Record
from schemas.wound import Wound

SURFACE = "surface/burn_surface.glb"
MEDIA = {".jpg": "image/jpeg", ".png": "image/png", ".heic": "image/heic"}
STALE_S = 60
"""A send still "sending" this long after it started was cut short (the server stopped): shown as failed."""


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
        PacsFailed: nothing is marked as sent."""
        target = web.endpoint(self.config.dicom)
        study = self.study(who, site_id, bundle_id)
        subject = _subject(site_id, bundle_id)
        started = PacsSend(
            id=uuid7(),
            subject_id=subject,
            endpoint=target.shown,
            state=PacsSendState.sending,
            study_uid=study.study_uid,
            requested_by=who.username,
            started_at=iso(utcnow()),
            instances=len(study.instances),
        )
        with self.db.write() as conn:
            pacs_sends.begin(conn, started)
        try:
            outcome = web.send(study, target)
        except PacsFailed as exc:
            with self.db.write() as conn:
                pacs_sends.finish(conn, started.id, PacsSendState.failed, iso(utcnow()), error=exc.detail)
                _audit(conn, who, subject, "dicom.send_failed", exc.detail)
            raise
        with self.db.write() as conn:
            pacs_sends.finish(
                conn,
                started.id,
                PacsSendState.sent,
                iso(utcnow()),
                instances=outcome.instances,
                already_there=outcome.already_there,
            )
            detail = (
                f"study {outcome.study_uid} to {outcome.endpoint}: {outcome.instances} objects stored"
                f" ({outcome.already_there} already there)"
            )
            _audit(conn, who, subject, "dicom.send", detail)
        return self.sends(who, site_id, bundle_id)[0]

    def sends(self, who: Principal, site_id: str, bundle_id: str) -> list[PacsSend]:
        """The case's sends, newest first (a send cut short by a stopped server reads as failed)."""
        self.cases.case(who, site_id, bundle_id)  # the same check as reading the case
        with self.db.read() as conn:
            found = pacs_sends.of_subject(conn, _subject(site_id, bundle_id))
        return [pacs_sends.settled(s, STALE_S) for s in found]


def _subject(site_id: str, bundle_id: str) -> str:
    return f"{site_id}/{bundle_id}"


def _audit(conn, who: Principal, subject: str, action: str, detail: str) -> None:
    audit.append(
        conn, action=action, user_id=who.user_id, device_id=None, kind="case", record_id=subject, detail=detail
    )
