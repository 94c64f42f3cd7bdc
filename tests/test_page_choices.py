"""No clinical field on a blank form pre-selects a value the clinician did not choose (issue 38): every select
starts at its blank option; the intake's tetanus history saved untouched is "unknown", and the tetanus advice
treats it so. The older tetanus summary is not asked any more but kept, and shown, where a record holds it."""

from __future__ import annotations

import re

import msgspec
import pytest

from base.web.pages.forms import form_fields
from base.web.pages.forms_spec import NOT_CHOSEN, NOT_RECORDED
from gateway.pages.encounter_view import FORM_PAGES
from schemas.accounts import Role
from schemas.burn_chart import RegionCharting
from schemas.patient import Encounter, Patient
from schemas.record_parts import Intake, TetanusStatus
from schemas.records import RECORD_TYPES, RecordKind
from tests.conftest import make_user
from tests.page_forms_helpers import IDS, Browser, flat
from tests.pages_helpers import post_form, sign_in

FORMS = [Patient, Encounter, RegionCharting, *(RECORD_TYPES[kind] for kind in FORM_PAGES.values())]
SELECTED = re.compile(r'<option value="([^"]+)" selected>')


@pytest.mark.parametrize("struct_type", FORMS, ids=lambda t: t.__name__)
def test_every_select_of_a_new_form_starts_blank(struct_type):
    selects = [f for f in flat(form_fields(struct_type, skip=IDS)) if f.kind == "select"]
    for f in selects:
        assert f.value == "", f"{struct_type.__name__}.{f.name} starts at {f.value!r}"
        assert f.choices[0][0] == "", f"{struct_type.__name__}.{f.name} has no blank option"


def test_the_blank_option_says_what_is_saved():
    intake = {f.name: f for f in form_fields(Intake, skip=IDS)}
    assert intake["tetanus_doses"].choices[0] == ("", NOT_RECORDED)
    fluids = {f.name: f for f in form_fields(RECORD_TYPES[RecordKind.resuscitation], skip=IDS)}
    assert fluids["formula"].choices[0] == ("", NOT_CHOSEN)
    assert 'Left as not chosen, "Parkland" is saved.' in fluids["formula"].help
    survey = {f.name: f for f in flat(form_fields(RECORD_TYPES[RecordKind.primary_survey], skip=IDS))}
    assert survey["airway.intervention"].choices[0] == ("", NOT_CHOSEN)
    assert survey["airway.intervention"].choices[1] == ("none", "No intervention")
    assert 'Left as not chosen, "No intervention" is saved.' in survey["airway.intervention"].help
    assert {f.name: f for f in form_fields(Patient, skip=IDS)}["sex"].choices[0] == ("", NOT_RECORDED)


@pytest.fixture
def clinician(client, services):
    make_user(services, "cleo", Role.clinician)
    sign_in(client, "cleo")
    return client


def _encounter(client) -> str:
    new = client.get("/patients/new").text
    patient_id = re.search(r'name="id" value="([^"]+)"', new).group(1)
    post_form(client, "/patients/new", {"id": patient_id, "given_name": "Achieng", "age_estimate_years": "30"})
    url = f"/patients/{patient_id}/encounters/new"
    encounter_id = re.search(r'name="id" value="([^"]+)"', client.get(url).text).group(1)
    typed = {"id": encounter_id, "mode": "emergency", "time_of_arrival": "2026-01-10T08:00"}
    assert post_form(client, url, typed).status_code == 303
    return encounter_id


def _form(html: str, slug: str) -> list[tuple[str, str]]:
    """What the browser sends for the part's form exactly as the page shows it."""
    form = re.search(rf'<form method="post" action="[^"]*/parts/{slug}".*?</form>', html, re.S).group(0)
    return Browser(form).pairs


def test_no_gateway_form_shows_a_value_chosen_on_a_blank_form(clinician):
    encounter_id = _encounter(clinician)
    patient_id = re.search(r'href="/patients/([0-9a-f-]+)"', clinician.get(f"/encounters/{encounter_id}").text)[1]
    pages = ["/patients/new", f"/patients/{patient_id}/encounters/new"]
    pages += [f"/encounters/{encounter_id}/parts/{slug}" for slug in FORM_PAGES]
    pages += [f"/encounters/{encounter_id}/burn-chart?region=trunk_anterior"]
    for url in pages:
        html = clinician.get(url).text
        assert 'id="field-' in html or 'id="region-' in html, url
        assert SELECTED.findall(html) == [], url
    assert 'name="tetanus_status"' not in clinician.get(f"/encounters/{encounter_id}/parts/intake").text


def test_a_blank_intake_saved_untouched_stores_tetanus_unknown_and_the_advice_says_so(clinician, services):
    encounter_id = _encounter(clinician)
    url = f"/encounters/{encounter_id}/parts/intake"
    sent = dict(_form(clinician.get(url).text, "intake"))
    assert sent["tetanus_doses"] == ""
    r = clinician.post(url, data=sent, follow_redirects=False)
    assert r.status_code == 303, r.text[-1500:]
    principal = services.accounts.authenticate(clinician.cookies["burnedge_session"])
    stored = services.records.get(principal, RecordKind.intake, encounter_id).data
    assert (stored["tetanus_status"], stored["tetanus_doses"]) == ("unknown", "unknown")
    support = services.decision_support.get(principal, encounter_id).data
    tetanus = next(r for r in support["recommendations"] if r["key"] == "tetanus")
    assert "unknown or fewer than 3 prior doses" in tetanus["text"] and "no vaccine needed" not in tetanus["text"]
    assert "Tetanus immune globulin" in tetanus["text"] or "tetanus immune globulin" in tetanus["text"]


def test_an_older_tetanus_summary_is_shown_read_only_and_kept_on_save(clinician, services):
    encounter_id = _encounter(clinician)
    principal = services.accounts.authenticate(clinician.cookies["burnedge_session"])
    older = Intake(encounter_id=encounter_id, tetanus_status=TetanusStatus.up_to_date)
    services.records.create(principal, RecordKind.intake, encounter_id, msgspec.to_builtins(older))
    url = f"/encounters/{encounter_id}/parts/intake"
    html = clinician.get(url).text
    assert 'name="tetanus_status"' not in html
    shown = re.search(r'<div class="alert alert-info" id="older-fields">.*?</div>', html, re.S).group(0)
    assert "<dt>Tetanus status</dt><dd>Up to date</dd>" in shown
    sent = dict(_form(html, "intake")) | {"tetanus_doses": "three_or_more"}
    assert clinician.post(url, data=sent, follow_redirects=False).status_code == 303
    stored = services.records.get(principal, RecordKind.intake, encounter_id).data
    assert (stored["tetanus_status"], stored["tetanus_doses"]) == ("up_to_date", "three_or_more")
    # A form shown again with an error still shows it.
    again = clinician.post(url, data=dict(_form(clinician.get(url).text, "intake")) | {"version": "2", "x": "1"})
    assert again.status_code == 422 and "<dd>Up to date</dd>" in again.text


def test_a_decline_without_a_reason_comes_back_beside_the_recommendation(clinician, services):
    encounter_id = _encounter(clinician)
    html = clinician.get(f"/encounters/{encounter_id}").text
    key = re.search(r'name="key" value="([^"]+)"', html).group(1)
    version = re.search(r'name="version" value="(\d+)"', html).group(1)
    url = f"/encounters/{encounter_id}/recommendations"
    token = re.search(r'name="csrf_token" value="([^"]+)"', html).group(1)
    sent = {"csrf_token": token, "version": version, "key": key, "state": "declined", "reason": "  "}
    r = clinician.post(url, data=sent, follow_redirects=False)
    assert r.status_code == 422 and "Not stored: say why the recommendation is declined" in r.text
    assert 'aria-invalid="true" aria-describedby="act-problem"' in r.text
