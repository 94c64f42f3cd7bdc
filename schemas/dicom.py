"""DICOM export to a hospital's PACS: how the PatientID is chosen, and each send as recorded (docs/dicom.md)."""

from __future__ import annotations

import enum

from schemas.base import Frozen


class PatientIdRule(enum.StrEnum):
    """How the DICOM PatientID is chosen (the `[dicom] patient_id_rule` setting); never empty."""

    record_number = "record_number"
    """The medical record number the clinic keyed; a patient without one gets `patient_id_prefix` and burnedge's
    own patient id."""
    burnedge_id = "burnedge_id"
    """Always `patient_id_prefix` and burnedge's own patient id (a PACS that must not see the clinic's numbers)."""


class PacsSendState(enum.StrEnum):
    sending = "sending"
    """Started; a send that never finished (the gateway stopped) reads as failed once it is older than a minute."""
    sent = "sent"
    """Every object of the study was stored and QIDO-RS found each one at the PACS."""
    failed = "failed"
    """Nothing is marked as sent: `error` says why; sending again stores each object once (stable UIDs)."""


class PacsSend(Frozen):
    """One send of an encounter (or a received case) to the PACS, as the pages show it."""

    id: str
    subject_id: str
    """The encounter id (clinic) or the case's bundle id (center)."""
    endpoint: str
    """The DICOMweb root it went to, without credentials."""
    state: PacsSendState
    study_uid: str
    requested_by: str
    started_at: str
    finished_at: str | None = None
    instances: int = 0
    """Objects in the study sent."""
    already_there: int = 0
    """Of those, how many the PACS held before (a re-send replaces them: it adds none)."""
    error: str = ""


class PacsOutcome(Frozen):
    """What the DICOMweb client reports of one STOW-RS and the QIDO-RS check after it."""

    endpoint: str
    study_uid: str
    instances: int
    already_there: int
