"""Healing per wound: each wound's track from its own analyses, and its measured share of the body beside the chart.

The tracks are computed by the analysis jobs (timeline.py, one folder per wound); this module reads them and adds
what is cheap to compute on reading: the wound's latest measured %TBSA against the burn chart. The wound pages and
API read it through gateway/wounds; the encounter snapshot (gateway/records/snapshot.py) reads it in its own
transaction.
"""

from __future__ import annotations

import datetime as dt
import sqlite3

import msgspec

from base.storage import records as store
from gateway.jobs import timeline
from gateway.storage import jobs
from processing.clinical.wound_share import Charted, Measured, body_share
from schemas.burn_chart import BurnChart
from schemas.clinical_results import Assessment
from schemas.config import Config
from schemas.jobs import BurnAnalysis
from schemas.longitudinal import TrackResult
from schemas.records import Record, RecordKind
from schemas.wound import Wound
from schemas.wound_healing import BodyShare, PatientHealing, WoundHealing

NO_WOUND_LABEL = "analyses of no wound (made before the patient's wounds were recorded)"


def wound_healing(conn: sqlite3.Connection, config: Config, record: Record) -> WoundHealing:
    """The wound's track and share; a wound without a measured visit has neither yet."""
    wound = record.value()
    track = timeline.read_track(conn, config, wound.patient_id, wound.id)
    return WoundHealing(
        wound_id=wound.id,
        label=wound.label,
        regions=list(wound.regions),
        state=wound.state.value,
        track=track,
        share=_share(conn, wound, track),
    )


def patient_healing(conn: sqlite3.Connection, config: Config, patient_id: str, wounds: list[Record]) -> PatientHealing:
    """One section per live wound, then one for analyses of no wound when the patient has any."""
    sections = [wound_healing(conn, config, w) for w in wounds if not w.meta.deleted]
    if any(job.wound_id is None for job in jobs.measured(conn, patient_id)):
        track = timeline.read_track(conn, config, patient_id, None)
        sections.append(WoundHealing(wound_id=None, label=NO_WOUND_LABEL, track=track))
    return PatientHealing(patient_id=patient_id, wounds=sections)


def _share(conn: sqlite3.Connection, wound: Wound, track: TrackResult | None) -> BodyShare | None:
    measured = [s for s in (track.sessions if track else []) if s.area_cm2 is not None and s.analysis]
    if not measured:
        return None
    last = measured[-1]
    job_id = last.analysis.rstrip("/").rsplit("/", 1)[-1]
    head = store.find_head(conn, RecordKind.burn_analysis, job_id)
    if head is None:
        return None
    analysis = msgspec.convert(head.data, BurnAnalysis)
    figures = Measured(
        percent=analysis.result.metrics.tbsa_percent, area_cm2=last.area_cm2, analysis=last.analysis, day=last.day
    )
    return body_share(list(wound.regions), figures, _charted(conn, wound.patient_id, analysis.encounter_id))


def _charted(conn: sqlite3.Connection, patient_id: str, encounter_id: str) -> Charted | None:
    """The measured visit's own chart, else the chart of the patient's latest encounter that has one (with the age
    the calculators used for it)."""
    encounters = store.list_heads(conn, RecordKind.encounter, parent_id=patient_id, limit=None)
    arrival = {e.meta.id: e.value().time_of_arrival for e in encounters if not e.meta.deleted}
    order = sorted(arrival, key=lambda e: (e == encounter_id, arrival[e]), reverse=True)
    for candidate in order:
        chart = store.find_head(conn, RecordKind.burn_chart, candidate)
        result = store.find_head(conn, RecordKind.assessment, candidate)
        if chart is None or chart.meta.deleted or result is None:
            continue
        age = msgspec.convert(result.data, Assessment).age_years
        if age is None:
            continue
        when = _day(arrival[candidate])
        return Charted(
            chart=msgspec.convert(chart.data, BurnChart),
            age_years=age,
            described_as=f"the burn chart of the encounter of {when} (version {chart.meta.version})",
        )
    return None


def _day(at: dt.datetime) -> str:
    """ "6 Dec 2026": a reader's date that never breaks inside at a line's end, as 2026-12-06 can."""
    return f"{at.day} {at:%b %Y}"
