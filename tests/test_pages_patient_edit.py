"""A patient is corrected, withdrawn with a reason, restored and merged with the same person's other record from
the pages: every change a new version, the earlier ones kept, each in the audit trail; nothing deleted."""

from __future__ import annotations

import re

import pytest

from base.storage import audit
from base.storage import records as store
from gateway.storage import jobs
from processing.fhir import bundle
from processing.fhir import record as fhir
from schemas.accounts import Role
from schemas.encounter_snapshot import Versioned
from schemas.ids import uuid7
from schemas.records import RecordKind
from tests.conftest import make_user
from tests.pages_helpers import post_form, sign_in


@pytest.fixture
def clinician(client, services):
    make_user(services, "cleo", Role.clinician)
    sign_in(client, "cleo")
    return client


def _new_patient(client, **fields) -> str:
    record_id = re.search(r'name="id" value="([^"]+)"', client.get("/patients/new").text).group(1)
    r = post_form(client, "/patients/new", {"id": record_id, **fields}, from_page="/patients/new")
    assert r.status_code == 303, r.text[:500]
    return record_id


def _new_encounter(client, patient_id: str) -> str:
    url = f"/patients/{patient_id}/encounters/new"
    record_id = re.search(r'name="id" value="([^"]+)"', client.get(url).text).group(1)
    form = {"id": record_id, "mode": "emergency", "time_of_arrival": "2026-12-03T08:30"}
    assert post_form(client, url, form).status_code == 303
    return record_id


def _new_wound(client, patient_id: str, label: str) -> str:
    page = f"/patients/{patient_id}"
    record_id = re.search(r'name="id" value="([^"]+)"', client.get(page).text).group(1)
    form = {"id": record_id, "label": label, "regions": "head_anterior"}
    assert post_form(client, f"{page}/wounds/new", form, from_page=page).status_code == 303
    return record_id


def _measured_visit(services, encounter_id: str, patient_id: str) -> None:
    """A finished 3D measurement of the encounter, as the job runner leaves its row."""
    with services.db.write() as conn:
        conn.execute(
            "INSERT INTO analysis_jobs (id, encounter_id, patient_id, input_digest, request, state, priority,"
            " max_attempts, next_attempt_at, pictures, result_status, created_at, created_by, user_id, finished_at)"
            " VALUES (?, ?, ?, 'digest', '{}', 'done', 0, 3, '', 8, 'ok', '2026-12-03T09:00:00+00:00', 'cleo', 'u',"
            " '2026-12-03T09:10:00+00:00')",
            (uuid7(), encounter_id, patient_id),
        )


def _head(services, kind: RecordKind, record_id: str):
    with services.db.read() as conn:
        return store.get_head(conn, kind, record_id)


def _history(services, kind: RecordKind, record_id: str):
    with services.db.read() as conn:
        return store.history(conn, kind, record_id)


def _actions(services, record_id: str, kind: RecordKind = RecordKind.patient) -> list[str]:
    with services.db.read() as conn:
        return [e.action for e in audit.entries(conn) if e.record_id == record_id and e.kind == kind.value]


def test_a_patient_is_corrected_through_the_form_and_the_old_details_stay_in_history(clinician, services):
    patient_id = _new_patient(clinician, given_name="Amina", family_name="Otieno", sex="female")
    form = clinician.get(f"/patients/{patient_id}/edit").text
    assert re.search(r'name="family_name"[^>]*value="Otieno"', form), "the form is filled from the record"
    assert 'name="version" value="1"' in form
    r = post_form(
        clinician, f"/patients/{patient_id}/edit", {"version": "1", "given_name": "Amina", "family_name": "Odhiambo"}
    )
    assert r.status_code == 303
    versions = _history(services, RecordKind.patient, patient_id)
    assert [v.data["family_name"] for v in versions] == ["Otieno", "Odhiambo"]
    assert "Amina Odhiambo" in clinician.get(f"/patients/{patient_id}").text
    assert _actions(services, patient_id) == ["record.create", "record.update"]


def test_a_correction_needs_a_name_as_a_new_patient_does(clinician, services):
    patient_id = _new_patient(clinician, given_name="Amina")
    r = post_form(clinician, f"/patients/{patient_id}/edit", {"version": "1", "given_name": ""})
    assert r.status_code == 422
    assert "a patient needs a name or a medical record number" in r.text
    assert _head(services, RecordKind.patient, patient_id).meta.version == 1


def test_a_correction_of_an_older_version_is_refused_and_shows_what_was_saved(clinician, services):
    patient_id = _new_patient(clinician, given_name="Amina", medical_record_number="MRN-1")
    post_form(
        clinician,
        f"/patients/{patient_id}/edit",
        {"version": "1", "given_name": "Amina", "medical_record_number": "MRN-2"},
    )
    r = post_form(clinician, f"/patients/{patient_id}/edit", {"version": "1", "given_name": "Aminah"})
    assert r.status_code == 409
    assert "while you were editing" in r.text and "MRN-2" in r.text
    assert 'name="version" value="2"' in r.text, "saving again corrects the current version"
    assert _head(services, RecordKind.patient, patient_id).data["given_name"] == "Amina"


def test_withdrawing_without_a_reason_stores_nothing(clinician, services):
    patient_id = _new_patient(clinician, given_name="Amina")
    r = post_form(clinician, f"/patients/{patient_id}/withdraw", {"version": "1", "reason": "  "})
    assert r.status_code == 422
    assert "Say why this record is withdrawn" in r.text
    head = _head(services, RecordKind.patient, patient_id)
    assert head.meta.version == 1 and not head.meta.deleted


def test_a_withdrawn_patient_leaves_the_list_shows_why_and_can_be_restored(clinician, services):
    patient_id = _new_patient(clinician, given_name="Amina", family_name="Otieno")
    _new_patient(clinician, given_name="Baraka")
    r = post_form(clinician, f"/patients/{patient_id}/withdraw", {"version": "1", "reason": "entered in error"})
    assert r.status_code == 303
    listing = clinician.get("/patients").text
    assert "Amina Otieno" not in listing and "Baraka" in listing
    page = clinician.get(f"/patients/{patient_id}").text
    assert "This record was withdrawn" in page and "entered in error" in page and "cleo" in page
    assert "New encounter" not in page
    r = post_form(clinician, f"/patients/{patient_id}/restore", {"version": "2"}, from_page=f"/patients/{patient_id}")
    assert r.status_code == 303
    head = _head(services, RecordKind.patient, patient_id)
    assert head.meta.version == 3 and not head.meta.deleted
    assert "Amina Otieno" in clinician.get("/patients").text
    assert _actions(services, patient_id) == ["record.create", "record.delete", "record.restore"]


def test_a_nurse_is_not_offered_withdrawing_and_may_not(client, services):
    make_user(services, "nina", Role.nurse)
    sign_in(client, "nina")
    patient_id = _new_patient(client, given_name="Amina")
    assert "Withdraw this record" not in client.get(f"/patients/{patient_id}").text
    r = post_form(client, f"/patients/{patient_id}/withdraw", {"version": "1", "reason": "duplicate"})
    assert r.status_code == 403
    assert not _head(services, RecordKind.patient, patient_id).meta.deleted


def test_a_merge_moves_encounters_and_wounds_and_withdraws_the_duplicate(clinician, services):
    keep = _new_patient(clinician, given_name="Amina", family_name="Otieno", medical_record_number="MRN-7")
    duplicate = _new_patient(clinician, given_name="Amina", family_name="Otieno ", date_of_birth="1990-04-02")
    encounter = _new_encounter(clinician, duplicate)
    wound = _new_wound(clinician, duplicate, "left forearm")
    choose = clinician.get(f"/patients/{keep}/merge?q=otieno").text
    assert f"/patients/{keep}/merge/{duplicate}" in choose
    compare = clinician.get(f"/patients/{keep}/merge/{duplicate}").text
    assert "1990-04-02" in compare and "MRN-7" in compare
    _measured_visit(services, encounter, duplicate)
    r = post_form(clinician, f"/patients/{keep}/merge/{duplicate}", {"version": "1", "reason": "registered twice"})
    assert r.status_code == 303, r.text[:500]
    with services.db.read() as conn:  # the healing track reads measured visits by patient: they follow
        assert [j.encounter_id for j in jobs.measured(conn, keep)] == [encounter]
        assert jobs.measured(conn, duplicate) == []

    moved = _history(services, RecordKind.encounter, encounter)
    assert [v.data["patient_id"] for v in moved] == [duplicate, keep]
    assert _head(services, RecordKind.wound, wound).data["patient_id"] == keep
    gone = _head(services, RecordKind.patient, duplicate)
    assert gone.meta.deleted and gone.data["merged_into"] == keep
    assert gone.meta.delete_reason == f"merged into Amina Otieno ({keep}): registered twice"
    assert _actions(services, encounter, RecordKind.encounter)[-1] == "record.merge"
    assert _actions(services, wound, RecordKind.wound)[-1] == "record.merge"
    assert _actions(services, duplicate)[-1] == "record.merge"
    kept_page = clinician.get(f"/patients/{keep}").text
    assert f"/encounters/{encounter}" in kept_page and "left forearm" in kept_page
    assert "Amina Otieno" in clinician.get(f"/patients/{duplicate}").text
    assert f'href="/patients/{keep}"' in clinician.get(f"/patients/{duplicate}").text
    with services.db.read() as conn:
        assert audit.verify(conn).ok, "the merge's versions match the audit trail"


def test_a_record_is_not_merged_into_itself_nor_into_a_withdrawn_one(clinician, services):
    keep = _new_patient(clinician, given_name="Amina")
    r = post_form(clinician, f"/patients/{keep}/merge/{keep}", {"version": "1", "reason": "same"})
    assert r.status_code == 422 and "cannot be merged into itself" in r.text
    assert not _head(services, RecordKind.patient, keep).meta.deleted
    other = _new_patient(clinician, given_name="Baraka")
    post_form(clinician, f"/patients/{keep}/withdraw", {"version": "1", "reason": "entered in error"})
    r = post_form(clinician, f"/patients/{keep}/merge/{other}", {"version": "1", "reason": "same"})
    assert r.status_code == 409 and "was withdrawn" in r.text
    assert not _head(services, RecordKind.patient, other).meta.deleted


def test_a_merge_needs_a_reason(clinician, services):
    keep, other = _new_patient(clinician, given_name="Amina"), _new_patient(clinician, given_name="Amina O")
    r = post_form(clinician, f"/patients/{keep}/merge/{other}", {"version": "1", "reason": ""})
    assert r.status_code == 422 and "Say why these are the same person" in r.text
    assert not _head(services, RecordKind.patient, other).meta.deleted


def test_the_api_merges_and_refuses_a_nurse(client, auth, services):
    ids = ["0190c0de-0000-7000-8000-00000000000a", "0190c0de-0000-7000-8000-00000000000b"]
    for i in ids:
        r = client.post("/api/v1/patients", json={"id": i, "given_name": "Amina"}, headers=auth["clinician"])
        assert r.status_code == 201
    body = {"duplicate_id": ids[1], "reason": "registered twice"}
    r = client.post(f"/api/v1/patients/{ids[0]}/merge", json=body, headers=auth["nurse"])
    assert r.status_code == 403
    r = client.post(f"/api/v1/patients/{ids[0]}/merge", json=body, headers=auth["clinician"])
    assert r.status_code == 200, r.text
    assert r.json()["duplicate"]["meta"]["deleted"] is True
    exported = fhir.patient(Versioned.of(_head(services, RecordKind.patient, ids[1])))
    bundle.model_of("Patient").model_validate(exported)
    assert exported["active"] is False
    assert exported["link"] == [
        {"other": {"identifier": fhir.record_identifier("patient", ids[0])}, "type": "replaced-by"}
    ]
    r = client.put(
        f"/api/v1/patients/{ids[0]}",
        json={"id": ids[0], "given_name": "Amina", "merged_into": ids[1]},
        headers={**auth["clinician"], "If-Match": '"1"'},
    )
    assert r.status_code == 422, "only a merge marks a patient as merged"
