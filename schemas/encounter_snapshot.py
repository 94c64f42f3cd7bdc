"""One encounter's record as read in one go: every part with the version read, the patient's wounds, the measured
visits of each, each wound's healing and the consultants' notes.

The gateway reads it once (gateway/records/snapshot.py) and everything about the encounter is made from it: the
decision support (processing/clinical/decision_inputs.py), the PDF report (processing/report), the FHIR export
(processing/fhir), the case bundle for the burn center (sync/case_snapshot.py) and the encounter's pages. None of
them reads the record on its own, so none can disagree with another about which version it showed.
"""

from __future__ import annotations

import datetime as dt
from pathlib import Path
from typing import Generic, TypeVar

import msgspec

from schemas.audit import AuditHead
from schemas.burn_chart import BurnChart
from schemas.clinical_results import Assessment, FluidPlan, InputRef
from schemas.decision_support import DecisionSupport, InputUsed
from schemas.jobs import BurnAnalysis
from schemas.patient import Encounter, Patient
from schemas.record_parts import Intake, Mechanism, PrimarySurvey, Resuscitation, SecondarySurvey
from schemas.records import RECORD_TYPES, Record, RecordKind
from schemas.transfer import Consultation
from schemas.wound import Wound
from schemas.wound_healing import WoundHealing

T = TypeVar("T")


class UnstoredRecord(ValueError):
    """A record part built in memory (a rule's test case) was asked for its stored version, which it has not."""


class Versioned(msgspec.Struct, Generic[T], frozen=True):
    """A record part, typed, and the version of it that was read."""

    value: T
    ref: InputRef
    stored: Record | None = None
    """The stored version as read (its metadata: who saved it, when); None for a part built in memory."""

    @classmethod
    def of(cls, record: Record) -> Versioned:
        meta = record.meta
        value = msgspec.convert(record.data, RECORD_TYPES[meta.kind])
        return cls(value, InputRef(kind=meta.kind.value, id=meta.id, version=meta.version), record)

    @property
    def record(self) -> Record:
        """The stored version, exactly as kept (what a case bundle sends)."""
        if self.stored is None:
            raise UnstoredRecord(f"{self.ref.kind} {self.ref.id} version {self.ref.version} was not read from storage")
        return self.stored

    def used(self, name: str, value: object) -> InputUsed:
        """One fact read from this part, as a recommendation lists it."""
        return InputUsed(name=name, value=_shown(value), kind=self.ref.kind, id=self.ref.id, version=self.ref.version)


class AnalysisVisit(msgspec.Struct, frozen=True):
    """One measured visit of one wound of the patient: the latest analysis of it at one encounter."""

    analysis: Versioned[BurnAnalysis]
    folder: Path
    """The analysis folder (analysis.json, surface/burn_surface.npz, segmentation/overlays/)."""
    visit: str
    """How the visit is named: "this encounter", or its date and day since injury."""
    day: float | None = None
    wound_id: str | None = None
    """The wound measured (None: a patient with no wound recorded)."""
    wound: str = ""
    """The wound's label ("left forearm"); empty when it has none."""


class EncounterSnapshot(msgspec.Struct, frozen=True):
    snapshot_id: str
    """This reading's id: the report's and the FHIR bundle's id when one is made from it."""
    made_at: dt.datetime
    """When it was read (aware): the clock the time-dependent rules and the fluid plan are judged at."""
    made_by: str
    software_version: str
    clinic: str
    patient: Versioned[Patient]
    encounter: Versioned[Encounter]
    intake: Versioned[Intake] | None = None
    primary: Versioned[PrimarySurvey] | None = None
    secondary: Versioned[SecondarySurvey] | None = None
    mechanism: Versioned[Mechanism] | None = None
    chart: Versioned[BurnChart] | None = None
    resuscitation: Versioned[Resuscitation] | None = None
    assessment: Versioned[Assessment] | None = None
    fluids_now: FluidPlan | None = None
    """The fluid plan recomputed at made_at (the rate to run now moves with the clock); only the report and FHIR
    export ask for it."""
    decision_support: Versioned[DecisionSupport] | None = None
    wounds: list[Versioned[Wound]] = msgspec.field(default_factory=list)
    """The patient's live wounds, oldest first."""
    encounter_analyses: list[AnalysisVisit] = msgspec.field(default_factory=list)
    """Every live finished analysis of this encounter, re-runs included, oldest first, each with its wound."""
    analyses: list[AnalysisVisit] = msgspec.field(default_factory=list)
    """The latest analysis of each wound at each of the patient's encounters, in the order the photos were taken."""
    healing: list[WoundHealing] = msgspec.field(default_factory=list)
    """Each wound's healing track and measured share of the body, in the order of `wounds` (then analyses of no
    wound, if any)."""
    consultations: list[Versioned[Consultation]] = msgspec.field(default_factory=list)
    audit_head: AuditHead | None = None
    """The audit chain's newest entry when this was read."""

    @property
    def report_id(self) -> str:
        return self.snapshot_id

    def parts(self) -> dict[RecordKind, Versioned]:
        """The encounter's parts recorded so far (withdrawn ones left out), by kind."""
        parts = {
            RecordKind.intake: self.intake,
            RecordKind.primary_survey: self.primary,
            RecordKind.secondary_survey: self.secondary,
            RecordKind.mechanism: self.mechanism,
            RecordKind.burn_chart: self.chart,
            RecordKind.resuscitation: self.resuscitation,
            RecordKind.assessment: self.assessment,
            RecordKind.decision_support: self.decision_support,
        }
        return {kind: part for kind, part in parts.items() if part is not None}

    def refs(self) -> list[InputRef]:
        parts = [self.patient, self.encounter, *self.parts().values()]
        parts += [a.analysis for a in self.analyses] + list(self.consultations) + list(self.wounds)
        return [p.ref for p in parts]


def _shown(value: object) -> str:
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, dt.datetime):
        return value.isoformat(timespec="minutes")
    if isinstance(value, dt.date):
        return value.isoformat()
    if value is None:
        return "not recorded"
    return str(getattr(value, "value", value))
