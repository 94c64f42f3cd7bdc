"""What the decision-support rules read: the encounter's record parts, each with the version it came from, taken
from the one encounter snapshot (schemas/encounter_snapshot.py)."""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass, field

from schemas.burn_chart import BurnChart
from schemas.clinical_results import Assessment, InputRef
from schemas.decision_support import InputUsed
from schemas.encounter_snapshot import EncounterSnapshot, Versioned
from schemas.jobs import BurnAnalysis
from schemas.longitudinal import TrackResult
from schemas.patient import Encounter, Patient
from schemas.record_parts import Intake, Mechanism, PrimarySurvey, Resuscitation, SecondarySurvey

HOURS_PER_DAY = 24.0
ADULT_FROM_YEARS = 18.0
"""Adult doses and targets apply from 18 years in the rules that draw the line there (pain, electrical urine)."""


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


NO_WOUND_TRACK = "burn"
"""How the recommendations name the track of analyses made before the patient's wounds were recorded."""


def decision_inputs(snapshot: EncounterSnapshot) -> DecisionInputs:
    """What the rules read, from the encounter's snapshot, judged at the time it was read."""
    assessment = snapshot.assessment
    refs = {visit.analysis.value.job_id: visit.analysis.ref for visit in snapshot.analyses}
    tracks = [
        WoundTrack(
            label=healing.label if healing.wound_id is not None else NO_WOUND_TRACK,
            track=healing.track,
            refs=[refs[job] for job in (_job_of(s.analysis) for s in healing.track.sessions) if job in refs],
            wound_id=healing.wound_id,
        )
        for healing in snapshot.healing
        if healing.track is not None
    ]
    return DecisionInputs(
        patient=snapshot.patient,
        encounter=snapshot.encounter,
        as_of=snapshot.made_at,
        age_years=assessment.value.age_years if assessment else None,
        intake=snapshot.intake,
        primary=snapshot.primary,
        secondary=snapshot.secondary,
        mechanism=snapshot.mechanism,
        chart=snapshot.chart,
        resuscitation=snapshot.resuscitation,
        assessment=assessment,
        analyses=[visit.analysis for visit in snapshot.encounter_analyses],
        tracks=tracks,
    )


def _job_of(analysis_url: str) -> str:
    """The job id at the end of a track session's analysis address (/api/v1/analyses/{id})."""
    return analysis_url.rstrip("/").rsplit("/", 1)[-1]
