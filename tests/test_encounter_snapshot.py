"""The one encounter snapshot over a real gateway database: typed all through, read in one transaction, and the same
reading behind decision support, the case bundle's summary and the encounter page."""

from __future__ import annotations

import datetime as dt
import re

import msgspec

from base.storage import audit
from base.storage import records as store
from gateway.records.snapshot import current_snapshot
from gateway.storage import jobs
from harness.bodies import encounter_body, now, patient_body, wound_body
from processing.clinical.decision_inputs import decision_inputs
from schemas.analysis import AnalysisResult, AnalysisStatus, BurnMetrics, ScaleSummary
from schemas.encounter_snapshot import EncounterSnapshot, Versioned
from schemas.ids import uuid7
from schemas.jobs import BurnAnalysis, JobInputs, JobState, StoredJob
from schemas.records import Record, RecordKind
from schemas.wound import Wound
from sync.case_snapshot import summarize
from tests.pages_helpers import sign_in


def _analysis(services, encounter_id: str, patient_id: str, area: float, minutes_ago: int, wound_id, job_wound):
    """A finished analysis stored as the runner stores it; its wound in the record (`wound_id`) or, as jobs queued
    before wounds were kept, only in its job row (`job_wound`)."""
    job_id = uuid7()
    at = (now() - dt.timedelta(minutes=minutes_ago)).isoformat()
    result = AnalysisResult(
        status=AnalysisStatus.ok,
        metrics=BurnMetrics(area_cm2=area, perimeter_cm=15.0, relief_max_mm=1.0, volume_cm3=0.3, burn_loops=1),
        scale=ScaleSummary(method="marker", mm_per_unit=1.0, uncertainty_percent=1.5),
        hours_since_injury=3.0,
    )
    record = BurnAnalysis(
        encounter_id=encounter_id,
        job_id=job_id,
        assets=[],
        requested_by="clinician",
        requested_at=at,
        completed_at=at,
        result=result,
        wound_id=wound_id,
    )
    job = StoredJob(
        id=job_id,
        encounter_id=encounter_id,
        patient_id=patient_id,
        input_digest=job_id,
        state=JobState.done,
        priority=0,
        max_attempts=1,
        next_attempt_at=at,
        pictures=0,
        created_at=at,
        created_by="clinician",
        user_id="u",
        wound_id=job_wound,
    )
    with services.db.write() as conn:
        jobs.insert(conn, job, JobInputs(pictures=[]))
        audit.insert_server_record(
            conn,
            kind=RecordKind.burn_analysis,
            record_id=job_id,
            parent_id=encounter_id,
            data=msgspec.json.encode(record),
            action="analysis.store",
        )
    return job_id


def test_one_reading_is_typed_and_feeds_decision_support_the_case_summary_and_the_page(client, services, auth):
    clin = auth["clinician"]
    patient = patient_body()
    assert client.post("/api/v1/patients", json=patient, headers=clin).status_code == 201
    encounter = encounter_body(patient["id"])
    assert client.post("/api/v1/encounters", json=encounter, headers=clin).status_code == 201
    forearm = wound_body(patient["id"])
    shin = wound_body(patient["id"], label="left shin", regions=["lower_leg_left_anterior"])
    for wound in (forearm, shin):
        assert client.post(f"/api/v1/patients/{patient['id']}/wounds", json=wound, headers=clin).status_code == 201
    first = _analysis(services, encounter["id"], patient["id"], 18.0, 30, forearm["id"], forearm["id"])
    rerun = _analysis(services, encounter["id"], patient["id"], 17.5, 20, forearm["id"], forearm["id"])
    older_shin = _analysis(services, encounter["id"], patient["id"], 6.1, 10, None, shin["id"])

    snap = current_snapshot(services.db, services.config, encounter["id"], "clinician")

    assert isinstance(snap, EncounterSnapshot) and isinstance(snap.encounter, Versioned)
    assert [type(w.value) for w in snap.wounds] == [Wound, Wound]
    assert all(isinstance(w.record, Record) and w.record.meta.version == 1 for w in snap.wounds)
    # Every analysis of the encounter (the re-run too) with its wound, the job row's for the older one...
    assert [(v.analysis.ref.id, v.wound_id) for v in snap.encounter_analyses] == [
        (first, forearm["id"]),
        (rerun, forearm["id"]),
        (older_shin, shin["id"]),
    ]
    assert all(isinstance(v.analysis.value, BurnAnalysis) for v in snap.encounter_analyses)
    # ...and one measured visit per wound: the re-run replaces the first.
    assert sorted(v.analysis.ref.id for v in snap.analyses) == sorted([rerun, older_shin])
    assert {v.wound for v in snap.analyses} == {"left forearm", "left shin"}

    # Decision support reads the same analyses and the same versions.
    inputs = decision_inputs(snap)
    assert [a.ref for a in inputs.analyses] == [v.analysis.ref for v in snap.encounter_analyses]
    assert inputs.as_of == snap.made_at and inputs.patient is snap.patient

    # The case summary counts the older analysis for the shin, whose job names it (it counted for no wound).
    wounds = {w.label: w for w in summarize(snap).wounds}
    assert (wounds["left forearm"].analyses, wounds["left forearm"].area_cm2) == (2, 17.5)
    assert (wounds["left shin"].analyses, wounds["left shin"].area_cm2) == (1, 6.1)
    assert summarize(snap).analyses == 3


def test_a_withdrawn_part_is_left_out_and_the_page_shows_the_reading(client, services, auth):
    clin = auth["clinician"]
    patient = patient_body()
    client.post("/api/v1/patients", json=patient, headers=clin)
    encounter = encounter_body(patient["id"])
    client.post("/api/v1/encounters", json=encounter, headers=clin)
    intake = {"encounter_id": encounter["id"], "no_known_allergies": True}
    url = f"/api/v1/encounters/{encounter['id']}/intake"
    put = client.put(url, json=intake, headers={**clin, "If-None-Match": "*"})
    assert put.status_code in (200, 201), put.text

    snap = current_snapshot(services.db, services.config, encounter["id"], "clinician")
    assert snap.intake is not None and snap.intake.value.no_known_allergies is True
    assert RecordKind.intake in snap.parts()

    gone = client.delete(url, params={"reason": "entered on the wrong patient"}, headers={**clin, "If-Match": "1"})
    assert gone.status_code in (200, 204), gone.text
    with services.db.read() as conn:
        assert store.find_head(conn, RecordKind.intake, encounter["id"]).meta.deleted
    after = current_snapshot(services.db, services.config, encounter["id"], "clinician")
    assert after.intake is None and RecordKind.intake not in after.parts()

    # The overview page is made from the same reading: the withdrawn intake is not shown as recorded.
    sign_in(client, "clinician")
    page = client.get(f"/encounters/{encounter['id']}").text
    intake_row = re.search(
        r"<tr>\s*<td[^>]*><a href=\"[^\"]+/parts/intake\">History[^<]*</a></td>(.*?)</tr>", page, re.S
    )
    assert intake_row is not None and "not recorded" in intake_row.group(1)
