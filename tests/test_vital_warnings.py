"""Vital signs outside the usual range for the patient's age get a warning beside the field, with its source, and
are saved once the clinician confirms them (processing/clinical/vital_ranges.py, the primary survey form)."""

from __future__ import annotations

import re

import pytest

from base.storage import records as store
from processing.clinical.vital_ranges import low_systolic, unusual_vitals
from schemas.accounts import Role
from schemas.record_parts import Breathing, Circulation, Exposure, PrimarySurvey
from schemas.records import RecordKind
from tests.conftest import make_user
from tests.pages_helpers import post_form, sign_in

EID = "0190c0de-0000-7000-8000-00000000e001"


def survey(hr=None, rr=None, sbp=None, temp=None) -> PrimarySurvey:
    return PrimarySurvey(
        encounter_id=EID,
        assessed_at="2026-12-06T08:00:00+00:00",
        breathing=Breathing(respiratory_rate_per_min=rr),
        circulation=Circulation(heart_rate_per_min=hr, systolic_bp_mmhg=sbp),
        exposure=Exposure(temperature_c=temp),
    )


def test_a_heart_rate_of_210_in_an_8_year_old_is_unusual_and_100_is_not():
    warned = unusual_vitals(survey(hr=210), 8)
    assert "outside the usual heart rate for this age (60–140 /min, PALS)" in warned["circulation.heart_rate_per_min"]
    assert unusual_vitals(survey(hr=100), 8) == {}
    assert unusual_vitals(survey(hr=170), 0.5) == {}  # an infant's usual rate


def test_breathing_rate_blood_pressure_and_temperature():
    assert "breathing rate" in unusual_vitals(survey(rr=70), 0.5)["breathing.respiratory_rate_per_min"]
    assert unusual_vitals(survey(rr=50), 0.5) == {}
    assert low_systolic(0.01) == 60 and low_systolic(0.5) == 70 and low_systolic(4) == 78 and low_systolic(30) == 90
    assert "hypotension" in unusual_vitals(survey(sbp=75), 4)["circulation.systolic_bp_mmhg"]
    assert "hypothermia" in unusual_vitals(survey(temp=34.2), 40)["exposure.temperature_c"]


def test_adults_are_warned_where_news2_scores_a_parameter_3_and_no_age_means_no_age_ranges():
    warned = unusual_vitals(survey(hr=131, rr=25, sbp=220, temp=39.1), 40)
    assert "NEWS2 scores a pulse of 40 /min or less, or 131 /min or more, 3" in warned["circulation.heart_rate_per_min"]
    assert "a breathing rate of 8 /min or less, or 25 /min or more" in warned["breathing.respiratory_rate_per_min"]
    assert "220 mmHg or more" in warned["circulation.systolic_bp_mmhg"]
    assert "fever" in warned["exposure.temperature_c"]
    assert unusual_vitals(survey(hr=130, rr=24, sbp=219, temp=39.0), 40) == {}  # the last values NEWS2 scores below 3
    assert "circulation.heart_rate_per_min" in unusual_vitals(survey(hr=40), 18)
    assert unusual_vitals(survey(hr=210, sbp=60), None) == {}


@pytest.fixture
def clinician(client, services):
    make_user(services, "cleo", Role.clinician)
    sign_in(client, "cleo")
    return client


def _ids(client, url: str) -> str:
    return re.search(r'name="id" value="([^"]+)"', client.get(url).text).group(1)


def test_the_form_warns_beside_the_field_stores_nothing_until_confirmed_then_saves(clinician, services):
    patient_id = _ids(clinician, "/patients/new")
    post_form(clinician, "/patients/new", {"id": patient_id, "given_name": "Kito", "age_estimate_years": "8"})
    url = f"/patients/{patient_id}/encounters/new"
    encounter_id = _ids(clinician, url)
    typed = {"id": encounter_id, "mode": "emergency", "time_of_arrival": "2026-12-06T08:30"}
    created = post_form(clinician, url, typed)
    assert created.status_code == 303, created.text[:400]
    form = f"/encounters/{encounter_id}/parts/primary-survey"
    values = {"assessed_at": "2026-12-06T08:40", "circulation.heart_rate_per_min": "210", "version": "0"}
    first = post_form(clinician, form, values, from_page=form)
    assert first.status_code == 422
    assert "210 /min is outside the usual heart rate for this age (60–140 /min, PALS)" in first.text
    assert 'id="unusual-values"' in first.text and 'value="210"' in first.text
    with services.db.read() as conn:
        assert store.find_head(conn, RecordKind.primary_survey, encounter_id) is None  # nothing stored yet
    saved = post_form(clinician, form, {**values, "confirm_unusual": "yes"}, from_page=form)
    assert saved.status_code == 303
    again = clinician.get(form).text
    assert "field-warning" in again and "outside the usual heart rate" in again and 'id="unusual-values"' not in again
