"""A new patient needs a name, a record number or, for an unknown patient, a temporary label: an empty New
patient form stores nothing and says what is needed, at the field, with what was typed kept."""

from __future__ import annotations

import re

import pytest

from base.storage import records as store
from schemas.accounts import Role
from schemas.records import RecordKind
from tests.conftest import make_user
from tests.pages_helpers import post_form, sign_in


@pytest.fixture
def nurse(client, services):
    make_user(services, "nina", Role.nurse)
    sign_in(client, "nina")
    return client


def _post_new(client, **fields):
    record_id = re.search(r'name="id" value="([^"]+)"', client.get("/patients/new").text).group(1)
    return record_id, post_form(client, "/patients/new", {"id": record_id, **fields}, from_page="/patients/new")


def _stored(services) -> int:
    with services.db.read() as conn:
        return len(store.list_heads(conn, RecordKind.patient))


def test_an_empty_new_patient_form_stores_nothing_and_says_what_is_needed(nurse, services):
    _, r = _post_new(nurse, sex="female", age_estimate_years="30")
    assert r.status_code == 422
    assert "a patient needs a name or a medical record number" in r.text
    assert re.search(r'name="age_estimate_years"[^>]*value="30"', r.text), "what was typed comes back"
    assert _stored(services) == 0
    assert "Unnamed patient" not in nurse.get("/patients").text


def test_an_unknown_patient_is_stored_under_a_temporary_label(nurse, services):
    record_id, r = _post_new(nurse, temporary_label="Unknown man, bay 3", age_estimate_years="40")
    assert r.status_code == 303
    assert "Unknown man, bay 3 (unknown patient)" in nurse.get(f"/patients/{record_id}").text
    assert "Unknown man, bay 3 (unknown patient)" in nurse.get("/patients").text


def test_a_record_number_alone_names_the_patient(nurse, services):
    record_id, r = _post_new(nurse, medical_record_number="MRN-77")
    assert r.status_code == 303
    assert "Record MRN-77" in nurse.get(f"/patients/{record_id}").text


def test_the_api_refuses_a_nameless_patient_with_the_field(client, auth, services):
    r = client.post("/api/v1/patients", json={"id": "0190c0de-0000-7000-8000-000000000001"}, headers=auth["nurse"])
    assert r.status_code == 422
    assert r.json()["errors"][0]["field"] == "$.given_name"
    assert _stored(services) == 0
