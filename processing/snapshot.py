"""One encounter's record as read in one snapshot: every part with the version read, the patient's wounds, the
measured visits of each, each wound's healing and the consultants' notes. The report (processing/report), the FHIR export
(processing/fhir) and the gateway's services all take this one type; neither document defines its own."""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass, field
from pathlib import Path

from processing.clinical.decision_inputs import Versioned
from schemas.audit import AuditHead
from schemas.burn_chart import BurnChart
from schemas.clinical_results import Assessment, FluidPlan, InputRef
from schemas.decision_support import DecisionSupport
from schemas.jobs import BurnAnalysis
from schemas.patient import Encounter, Patient
from schemas.record_parts import Intake, Mechanism, PrimarySurvey, Resuscitation, SecondarySurvey
from schemas.transfer import Consultation
from schemas.wound import Wound
from schemas.wound_healing import WoundHealing


@dataclass(frozen=True)
class AnalysisVisit:
    """One measured visit of the patient, with its analysis folder."""

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


@dataclass(frozen=True)
class EncounterSnapshot:
    report_id: str
    made_at: dt.datetime
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
    """The fluid plan recomputed at made_at: the rate to run now moves with the clock."""
    decision_support: Versioned[DecisionSupport] | None = None
    wounds: list[Versioned[Wound]] = field(default_factory=list)
    """The patient's live wounds, oldest first."""
    analyses: list[AnalysisVisit] = field(default_factory=list)
    """The latest analysis of each wound at each visit, in the order the photos were taken."""
    healing: list[WoundHealing] = field(default_factory=list)
    """Each wound's healing track and measured share of the body, in the order of `wounds`."""
    consultations: list[Versioned[Consultation]] = field(default_factory=list)
    audit_head: AuditHead | None = None
    """The audit chain's newest entry before this report was made."""

    def refs(self) -> list[InputRef]:
        parts = [self.patient, self.encounter, self.intake, self.primary, self.secondary, self.mechanism, self.chart]
        parts += [self.resuscitation, self.assessment, self.decision_support]
        parts += [a.analysis for a in self.analyses] + list(self.consultations) + list(self.wounds)
        return [p.ref for p in parts if p is not None]
