"""What a DICOM study is made from: typed, read by the gateway from its record (gateway/documents/dicom.py) or by
the burn center from a received case (center/pacs.py), so neither server's storage is needed here."""

from __future__ import annotations

import datetime as dt

import msgspec

from schemas.dicom import PatientIdRule
from schemas.jobs import BurnAnalysis
from schemas.patient import Encounter, Patient
from schemas.wound import Wound


class Photo(msgspec.Struct, frozen=True):
    """One stored picture, its bytes as received."""

    asset_id: str
    data: bytes
    media_type: str
    """"image/jpeg", "image/png" or "image/heic"."""
    filename: str = ""
    taken_at: dt.datetime | None = None
    """From the camera clock, with its offset; None when the camera gave no offset."""
    camera_make: str = ""
    camera_model: str = ""
    wound_id: str | None = None


class Analysis(msgspec.Struct, frozen=True):
    """One finished analysis and its painted surface (glTF binary, in mm when scaled)."""

    record: BurnAnalysis
    surface_glb: bytes | None = None


class StudyInput(msgspec.Struct, frozen=True):
    patient: Patient
    encounter: Encounter
    wounds: list[Wound]
    photos: list[Photo]
    """The photos the analyses used (and any other of the encounter's the caller chose), each once."""
    analyses: list[Analysis]
    report_pdf: bytes | None
    made_at: dt.datetime
    software_version: str
    institution: str = ""
    patient_id_rule: PatientIdRule = PatientIdRule.record_number
    patient_id_prefix: str = "BE-"
    issuer_of_patient_id: str = ""

    def wound(self, wound_id: str | None) -> Wound | None:
        return next((w for w in self.wounds if w.id == wound_id), None) if wound_id else None
