"""The clinic's pages over the real app (TestClient): sign-in, patients, encounters and the record forms, with
the API's validation, optimistic concurrency, escaping, CSRF and roles. The browser tests drive the same pages in
Chromium (tests/test_browser_clinic.py)."""

from __future__ import annotations

import pytest

from harness.processes import PASSWORD
from schemas.accounts import Role
from schemas.records import RecordKind
from tests.conftest import make_user
from tests.pages_helpers import csrf_from, post_form, sign_in


@pytest.fixture
def nurse(client, services):
    make_user(services, "nina", Role.nurse)
    sign_in(client, "nina")
    return client


def _new_patient(client, **fields) -> str:
    page = client.get("/patients/new")
    record_id = __import__("re").search(r'name="id" value="([^"]+)"', page.text).group(1)
    r = post_form(client, "/patients/new", {"id": record_id, **fields}, from_page="/patients/new")
    assert r.status_code == 303, r.text[:500]
    return r.headers["location"].rsplit("/", 1)[1]


def _new_encounter(client, patient_id: str) -> str:
    url = f"/patients/{patient_id}/encounters/new"
    page = client.get(url)
    record_id = __import__("re").search(r'name="id" value="([^"]+)"', page.text).group(1)
    r = post_form(
        client,
        url,
        {
            "id": record_id,
            "mode": "emergency",
            "time_of_arrival": "2026-12-03T08:30",
            "time_of_injury": "2026-12-03T07:10",
        },
    )
    assert r.status_code == 303, r.text[:500]
    return r.headers["location"].rsplit("/", 1)[1]


def test_pages_redirect_to_sign_in_and_back(client, services):
    r = client.get("/patients?q=ab", follow_redirects=False)
    assert r.status_code == 303 and r.headers["location"].startswith("/sign-in?next=")
    make_user(services, "nina", Role.nurse)
    sign_in(client, "nina")
    assert "Patients" in client.get("/patients").text


def test_a_wrong_password_shows_the_form_again_without_signing_in(client, services):
    make_user(services, "nina", Role.nurse)
    form = client.get("/sign-in")
    r = client.post(
        "/sign-in", data={"csrf_token": csrf_from(form.text), "username": "nina", "password": "nope-nope-nope"}
    )
    assert r.status_code == 401 and 'value="nina"' in r.text
    assert client.get("/patients", follow_redirects=False).status_code == 303


def test_create_search_and_open_a_patient(nurse, services):
    patient_id = _new_patient(
        nurse, given_name="Amina", family_name="Diallo", medical_record_number="MRN-1042", sex="female"
    )
    assert "Amina Diallo" in nurse.get(f"/patients/{patient_id}").text
    assert "Amina Diallo" in nurse.get("/patients?q=mrn-1042").text
    assert "Amina Diallo" not in nurse.get("/patients?q=nobody").text


def test_a_double_submitted_new_patient_form_stores_one_patient(nurse, services):
    page = nurse.get("/patients/new")
    record_id = __import__("re").search(r'name="id" value="([^"]+)"', page.text).group(1)
    for _ in range(2):
        r = nurse.post(
            "/patients/new",
            data={"csrf_token": csrf_from(page.text), "id": record_id, "given_name": "Ali"},
            follow_redirects=False,
        )
        assert r.status_code == 303
    principal = services.accounts.authenticate(nurse.cookies["burnedge_session"])
    assert len(services.records.list_records(principal, RecordKind.patient)) == 1


def test_invalid_input_is_shown_again_with_the_errors_and_nothing_is_stored(nurse, services):
    page = nurse.get("/patients/new")
    record_id = __import__("re").search(r'name="id" value="([^"]+)"', page.text).group(1)
    r = nurse.post(
        "/patients/new",
        data={"csrf_token": csrf_from(page.text), "id": record_id, "given_name": "Kofi", "weight_kg": "9000"},
    )
    assert r.status_code == 422
    assert 'value="Kofi"' in r.text and 'value="9000"' in r.text and 'aria-invalid="true"' in r.text
    principal = services.accounts.authenticate(nurse.cookies["burnedge_session"])
    assert services.records.list_records(principal, RecordKind.patient) == []


def test_a_name_with_markup_is_shown_as_text(nurse):
    patient_id = _new_patient(nurse, given_name="<script>alert(1)</script>")
    html = nurse.get(f"/patients/{patient_id}").text
    assert "<script>alert(1)</script>" not in html
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in html


def test_a_form_without_the_csrf_token_is_refused_and_nothing_stored(nurse, services):
    r = nurse.post("/patients/new", data={"id": "0190c0de-0000-7000-8000-000000000001", "given_name": "Eve"})
    assert r.status_code == 403
    r = nurse.post("/patients/new", data={"csrf_token": "forged", "id": "0190c0de-0000-7000-8000-000000000001"})
    assert r.status_code == 403
    principal = services.accounts.authenticate(nurse.cookies["burnedge_session"])
    assert services.records.list_records(principal, RecordKind.patient) == []


def test_encounter_parts_save_and_someone_else_saving_first_is_explained(nurse, services):
    patient_id = _new_patient(nurse, given_name="Sara", weight_kg="60", weight_source="measured")
    encounter_id = _new_encounter(nurse, patient_id)
    url = f"/encounters/{encounter_id}/parts/mechanism"
    r = post_form(nurse, url, {"version": "0", "type": "scald", "agent": "boiling water"})
    assert r.status_code == 303 and "saved=mechanism" in r.headers["location"]
    stale = csrf_from(nurse.get(url).text)
    assert post_form(nurse, url, {"version": "1", "type": "scald", "agent": "tea"}).status_code == 303
    r = nurse.post(url, data={"csrf_token": stale, "version": "1", "type": "flame", "agent": "kerosene"})
    assert r.status_code == 409
    assert "while you were editing" in r.text and 'value="kerosene"' in r.text
    principal = services.accounts.authenticate(nurse.cookies["burnedge_session"])
    assert services.records.get(principal, RecordKind.mechanism, encounter_id).data["agent"] == "tea"


@pytest.fixture
def clinician(client, services):
    make_user(services, "cleo", Role.clinician)
    sign_in(client, "cleo")
    return client


def test_charting_a_region_updates_tbsa_and_fluids(clinician, services):
    nurse = clinician
    patient_id = _new_patient(
        nurse, given_name="Omar", weight_kg="70", weight_source="measured", age_estimate_years="30"
    )
    encounter_id = _new_encounter(nurse, patient_id)
    url = f"/encounters/{encounter_id}/burn-chart/regions/trunk_anterior"
    r = post_form(
        nurse,
        url,
        {"version": "0", "deep_partial_percent": "50"},
        from_page=f"/encounters/{encounter_id}/burn-chart?region=trunk_anterior",
        follow=True,
    )
    assert r.status_code == 200, r.text[-1500:]
    assert "6.5 %" in r.text  # half of the adult anterior trunk (13 %)
    assert "mL/h" in r.text
    bad = post_form(
        nurse,
        url,
        {"version": "1", "deep_partial_percent": "80", "full_thickness_percent": "40"},
        from_page=f"/encounters/{encounter_id}/burn-chart?region=trunk_anterior",
    )
    assert bad.status_code == 422 and "at most 100 %" in bad.text


def test_a_record_the_role_may_not_read_gets_the_apis_answer(client, services):
    make_user(services, "ada", Role.admin)
    make_user(services, "nina", Role.nurse)
    sign_in(client, "nina")
    patient_id = _new_patient(client, given_name="Lena")
    encounter_id = _new_encounter(client, patient_id)
    client.post("/sign-out", data={"csrf_token": csrf_from(client.get("/patients").text)})
    sign_in(client, "ada", next="/account/password")
    api = client.get(f"/api/v1/encounters/{encounter_id}")
    page = client.get(f"/encounters/{encounter_id}")
    assert page.status_code == api.status_code
    assert client.get("/encounters/0190c0de-0000-7000-8000-00000000dead").status_code in (403, 404)


def test_repeated_failed_sign_ins_are_slowed_as_the_apis_logins_are(client, services):
    make_user(services, "nina", Role.nurse)
    token = csrf_from(client.get("/sign-in").text)
    statuses = [
        client.post(
            "/sign-in", data={"csrf_token": token, "username": "nina", "password": "wrong password!"}
        ).status_code
        for _ in range(services.config.security.login_free_failures + 1)
    ]
    assert statuses == [401] * len(statuses)  # the last of these failures starts the delay
    # Even the right password waits out the delay: the form says so rather than signing in.
    r = client.post("/sign-in", data={"csrf_token": token, "username": "nina", "password": PASSWORD})
    assert r.status_code == 429 and "wait" in r.text and "Sign out" not in r.text


def test_signing_out_ends_the_session_for_the_cookie_too(nurse, services):
    cookie = nurse.cookies["burnedge_session"]
    nurse.post("/sign-out", data={"csrf_token": csrf_from(nurse.get("/patients").text)})
    nurse.cookies.set("burnedge_session", cookie)
    r = nurse.get("/patients", follow_redirects=False)
    assert r.status_code == 303 and r.headers["location"].startswith("/sign-in")


def test_the_referral_card_names_undecided_criteria_in_words_not_codes(client, services):
    make_user(services, "nina", Role.nurse)
    sign_in(client, "nina")
    encounter_id = _new_encounter(client, _new_patient(client, given_name="Lena"))
    html = client.get(f"/encounters/{encounter_id}").text
    assert "Not yet judged (record what is missing): Thermal: full-thickness burns (any size)" in html
    assert "aba2022." not in html
