"""What the decision-support rules read: the encounter's record parts, each with the version it came from."""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass, field
from typing import Generic, TypeVar

from schemas.burn_chart import BurnChart
from schemas.clinical_results import Assessment, InputRef
from schemas.decision_support import InputUsed
from schemas.jobs import BurnAnalysis
from schemas.longitudinal import TrackResult
from schemas.patient import Encounter, Patient
from schemas.record_parts import Intake, Mechanism, PrimarySurvey, Resuscitation, SecondarySurvey

T = TypeVar("T")

HOURS_PER_DAY = 24.0
ADULT_FROM_YEARS = 18.0
"""Adult doses and targets apply from 18 years in the rules that draw the line there (pain, electrical urine)."""


@dataclass(frozen=True)
class Versioned(Generic[T]):
    """A record part and the version of it that was read."""

    value: T
    ref: InputRef

    def used(self, name: str, value: object) -> InputUsed:
        """One fact read from this part, as a recommendation lists it."""
        return InputUsed(name=name, value=_shown(value), kind=self.ref.kind, id=self.ref.id, version=self.ref.version)


@dataclass(frozen=True)
class WoundTrack:
    """One wound's healing track and the analyses it was made from."""

    label: str
    """The wound's short name ("left forearm"); the recommendations name it when the patient has several."""
    track: TrackResult
    refs: list[InputRef] = field(default_factory=list)
    wound_id: str | None = None


@dataclass(frozen=True)
class DecisionInputs:
    patient: Versioned[Patient]
    encounter: Versioned[Encounter]
    as_of: dt.datetime
    """The clock time the time-dependent rules are judged at (aware)."""
    age_years: float | None = None
    """Age at injury, as the calculators worked it out (from the assessment)."""
    intake: Versioned[Intake] | None = None
    primary: Versioned[PrimarySurvey] | None = None
    secondary: Versioned[SecondarySurvey] | None = None
    mechanism: Versioned[Mechanism] | None = None
    chart: Versioned[BurnChart] | None = None
    resuscitation: Versioned[Resuscitation] | None = None
    assessment: Versioned[Assessment] | None = None
    analyses: list[Versioned[BurnAnalysis]] = field(default_factory=list)
    tracks: list[WoundTrack] = field(default_factory=list)
    """Each wound's healing track, for the wounds with a measured visit (never one track over several wounds)."""

    def refs(self) -> list[InputRef]:
        parts = [self.patient, self.encounter, self.intake, self.primary, self.secondary, self.mechanism]
        parts += [self.chart, self.resuscitation, self.assessment, *self.analyses]
        seen = {(p.ref.kind, p.ref.id): p.ref for p in parts if p is not None}
        for ref in (r for t in self.tracks for r in t.refs):
            seen.setdefault((ref.kind, ref.id), ref)
        return list(seen.values())

    @property
    def injury_time(self) -> dt.datetime | None:
        return self.encounter.value.time_of_injury

    def hours_since_injury(self) -> float | None:
        if self.injury_time is None:
            return None
        return (self.as_of - self.injury_time).total_seconds() / 3600

    def days_since_injury(self) -> float | None:
        hours = self.hours_since_injury()
        return None if hours is None else hours / HOURS_PER_DAY

    def age_used(self) -> InputUsed | None:
        """The age fact, read from the assessment that computed it (else the patient record it comes from)."""
        if self.age_years is None:
            return None
        source = self.assessment if self.assessment is not None else self.patient
        return source.used("age at injury", f"{self.age_years:g} y")

    def weight_used(self) -> tuple[float | None, InputUsed | None]:
        """The weight the calculators use: this encounter's, else the patient's."""
        if self.encounter.value.weight_kg is not None:
            weight = self.encounter.value.weight_kg
            return weight, self.encounter.used("weight", f"{weight:g} kg (this encounter)")
        weight = self.patient.value.weight_kg
        if weight is None:
            return None, None
        how = self.patient.value.weight_source
        return weight, self.patient.used("weight", f"{weight:g} kg" + (f" ({how.value})" if how else ""))


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
