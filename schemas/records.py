"""Versioned record envelopes: what the store keeps and what the API and change feed return."""

from __future__ import annotations

import enum

import msgspec

from schemas.base import Frozen, Id, ShortText, Timestamp
from schemas.burn_chart import BurnChart
from schemas.clinical_results import Assessment
from schemas.decision_support import DecisionSupport
from schemas.jobs import BurnAnalysis
from schemas.patient import Encounter, Patient
from schemas.record_parts import Intake, Mechanism, PrimarySurvey, Resuscitation, SecondarySurvey
from schemas.transfer import Consultation
from schemas.wound import Wound


class RecordKind(enum.StrEnum):
    patient = "patient"
    encounter = "encounter"
    intake = "intake"
    primary_survey = "primary_survey"
    secondary_survey = "secondary_survey"
    mechanism = "mechanism"
    burn_chart = "burn_chart"
    resuscitation = "resuscitation"
    assessment = "assessment"
    """Calculator results; written by the server only."""
    burn_analysis = "burn_analysis"
    """A finished 3D burn analysis of an encounter's pictures; written by the gateway's workers only."""
    consultation = "consultation"
    """A burn-center consultant's note on an encounter, as received over sync; written by the gateway only."""
    decision_support = "decision_support"
    """Recommendations computed from the record, each pending, accepted or declined by a clinician; written by the
    gateway only (a clinician's act through POST .../decision-support/acts)."""
    wound = "wound"
    """One burn of a patient, tracked across encounters until it closes (gateway/wounds/)."""

    @property
    def label(self) -> str:
        """How people say it: "burn chart", "primary survey"."""
        return self.value.replace("_", " ")


RECORD_TYPES: dict[RecordKind, type[msgspec.Struct]] = {
    RecordKind.patient: Patient,
    RecordKind.encounter: Encounter,
    RecordKind.intake: Intake,
    RecordKind.primary_survey: PrimarySurvey,
    RecordKind.secondary_survey: SecondarySurvey,
    RecordKind.mechanism: Mechanism,
    RecordKind.burn_chart: BurnChart,
    RecordKind.resuscitation: Resuscitation,
    RecordKind.assessment: Assessment,
    RecordKind.burn_analysis: BurnAnalysis,
    RecordKind.consultation: Consultation,
    RecordKind.decision_support: DecisionSupport,
    RecordKind.wound: Wound,
}

PATIENT_RECORDS = frozenset({RecordKind.encounter, RecordKind.wound})
"""Records of a patient: their parent is the patient their `patient_id` names, fixed once they are created."""

# Encounter parts are one per encounter: their record id is the encounter's id.
ENCOUNTER_PARTS = frozenset(
    {
        RecordKind.intake,
        RecordKind.primary_survey,
        RecordKind.secondary_survey,
        RecordKind.mechanism,
        RecordKind.burn_chart,
        RecordKind.resuscitation,
        RecordKind.assessment,
        RecordKind.decision_support,
    }
)
COMPUTED_PARTS = frozenset({RecordKind.assessment, RecordKind.decision_support})
"""Encounter parts the gateway computes from the others."""


class RecordMeta(Frozen):
    kind: RecordKind
    id: Id
    version: int
    """Starts at 1; every change writes the next version."""
    created_at: Timestamp
    updated_at: Timestamp
    updated_by: ShortText
    device_id: ShortText | None
    deleted: bool = False
    delete_reason: str | None = None
    seq: int = 0
    """Position in the gateway's change feed."""


class Record(Frozen):
    """One version of a record: metadata plus the record's data as a plain JSON object."""

    meta: RecordMeta
    data: dict

    def value(self) -> msgspec.Struct:
        """The data as its kind's Struct (RECORD_TYPES): read fields by name, typed, never by string key."""
        return msgspec.convert(self.data, RECORD_TYPES[self.meta.kind])


class RecordHistory(Frozen):
    kind: RecordKind
    id: Id
    versions: list[Record]


class EncounterRecord(Frozen):
    """An encounter and every part of its record, read in one snapshot."""

    encounter: Record
    parts: dict[RecordKind, Record]
    """The current version of each part recorded so far, the calculator results included."""
