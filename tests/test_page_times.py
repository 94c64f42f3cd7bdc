"""Date-times on the clinic's pages: typed in the clinic's zone (`[gateway] timezone`), labelled with it, stored in
UTC; a time too far ahead of the clinic clock comes back on the form, beside its field, with what was typed.

The real-browser round trip at phone width is in tests/test_browser_times.py.
"""

from __future__ import annotations

import datetime as dt
import re
import zoneinfo

import msgspec
import pytest
from litestar.testing import TestClient

from base.web.pages.clinic_time import ClinicClock, offset_text
from base.web.pages.forms import form_fields, parse_form
from gateway.app import create_app
from gateway.records.validation import future_message
from schemas.accounts import Role
from schemas.config import Config, GatewayConfig, load_config
from schemas.errors import InvalidInput
from schemas.patient import Encounter
from schemas.record_parts import PrimarySurvey, Resuscitation
from schemas.records import RecordKind
from tests.conftest import FAST_SECURITY, make_user
from tests.page_forms_helpers import EID, IDS, PID, flat, render
from tests.pages_helpers import post_form, sign_in

NAIROBI = zoneinfo.ZoneInfo("Africa/Nairobi")  # UTC+3 all year


def test_offsets_read_as_people_write_them():
    assert offset_text(dt.timedelta(hours=3)) == "UTC+03:00"
    assert offset_text(dt.timedelta(hours=-3, minutes=-30)) == "UTC-03:30"
    assert offset_text(dt.timedelta(hours=5, minutes=45)) == "UTC+05:45"
    assert offset_text(None) == "UTC+00:00"


def test_the_clinic_clock_names_its_zone_offset_and_tolerance():
    clock = ClinicClock.from_setting("Africa/Nairobi", 300)
    assert clock.label() == "Africa/Nairobi, UTC+03:00" and clock.offset_minutes() == 180
    assert clock.tolerance_text() == "Up to 5 minutes ahead of the clinic clock is accepted."
    assert clock.help() == "Clinic time (Africa/Nairobi). Up to 5 minutes ahead of the clinic clock is accepted."
    assert ClinicClock.from_setting("Africa/Nairobi", 90).tolerance_text().startswith("Up to 90 seconds")
    assert (
        ClinicClock.from_setting("Africa/Nairobi", 0).tolerance_text() == "A time ahead of the clinic clock is refused."
    )
    # Daylight saving: the offset is the one at the moment asked about.
    paris = ClinicClock.from_setting("Europe/Paris")
    assert paris.label(dt.datetime(2026, 1, 15, tzinfo=dt.UTC)) == "Europe/Paris, UTC+01:00"
    assert paris.label(dt.datetime(2026, 7, 15, tzinfo=dt.UTC)) == "Europe/Paris, UTC+02:00"
    machine = ClinicClock()
    assert machine.zone_name() and machine.offset() == dt.datetime.now().astimezone().utcoffset()
    with pytest.raises(ValueError, match="not a time zone name"):
        ClinicClock.from_setting("Mars/Olympus")


def test_the_timezone_setting_is_checked_when_the_config_loads():
    assert load_config(None, environ={"BURNEDGE_GATEWAY_TIMEZONE": "Africa/Nairobi"}).gateway.timezone == (
        "Africa/Nairobi"
    )
    assert load_config(None, environ={}).gateway.timezone == ""
    with pytest.raises(InvalidInput, match="'Mars/Olympus' is not a time zone name"):
        load_config(None, environ={"BURNEDGE_GATEWAY_TIMEZONE": "Mars/Olympus"})
    with pytest.raises(msgspec.ValidationError):
        msgspec.convert({"timezone": "../etc/passwd"}, GatewayConfig)


def test_datetime_fields_are_labelled_with_the_clinic_zone_and_read_in_it():
    clock = ClinicClock.from_setting("Africa/Nairobi", 300)
    fields = {f.name: f for f in form_fields(Encounter, skip=IDS, clock=clock)}
    injury = fields["time_of_injury"]
    assert injury.label == "Time of injury (Africa/Nairobi, UTC+03:00)"
    assert "Up to 5 minutes ahead of the clinic clock is accepted." in injury.help
    assert (injury.zone_offset, injury.zone_text) == (180, "UTC+03:00")
    assert fields["clinician"].zone_offset is None and "(" not in fields["clinician"].label
    html = render(list(fields.values()))
    assert 'data-clinic-offset="180"' in html and 'data-clinic-offset-text="UTC+03:00"' in html
    assert '<label for="field-time_of_injury">Time of injury (Africa/Nairobi, UTC+03:00)' in html
    raw = {"mode": ["emergency"], "time_of_arrival": ["2026-03-01T10:15"], "time_of_injury": ["2026-03-01T09:05"]}
    enc = parse_form(Encounter, raw, fixed={"id": EID, "patient_id": PID}, tz=clock.tz)
    assert enc.time_of_arrival == dt.datetime(2026, 3, 1, 7, 15, tzinfo=dt.UTC)
    assert enc.time_of_injury.utcoffset() == dt.timedelta(0) and enc.time_of_injury.hour == 6
    # Nested and list datetimes too: every one comes back in UTC, shown again as clinic wall time.
    survey = parse_form(PrimarySurvey, {"assessed_at": ["2026-03-01T23:30"]}, fixed={"encounter_id": EID}, tz=NAIROBI)
    assert survey.assessed_at == dt.datetime(2026, 3, 1, 20, 30, tzinfo=dt.UTC)
    shown = {f.name: f for f in form_fields(PrimarySurvey, value=survey, skip=IDS, clock=clock)}
    assert shown["assessed_at"].value == "2026-03-01T23:30"
    rows = {f.name: f for f in flat(form_fields(Resuscitation, skip=IDS, clock=clock))}
    assert rows["fluid_given[0].given_at"].label == "Given at (Africa/Nairobi, UTC+03:00)"


def test_the_future_message_is_in_the_clinic_zone():
    config = Config(gateway=GatewayConfig(timezone="Africa/Nairobi"))
    now = dt.datetime(2026, 3, 1, 9, 25, tzinfo=dt.UTC)
    text = future_message(dt.datetime(2026, 3, 1, 11, 30, tzinfo=dt.UTC), now, config)
    assert text == (
        "2026-03-01 14:30 is in the future: 2 h 05 min ahead of the clinic clock (now 12:25, Africa/Nairobi). "
        "Check the time entered (up to 5 min ahead is accepted) and the device's clock."
    )


@pytest.fixture
def nairobi(tmp_path):
    config = Config(
        gateway=GatewayConfig(database=str(tmp_path / "gateway.sqlite3"), timezone="Africa/Nairobi"),
        security=FAST_SECURITY,
    )
    app = create_app(config)
    with TestClient(app) as client:
        make_user(app.state.services, "cleo", Role.clinician)
        sign_in(client, "cleo")
        yield client, app.state.services


def _ids(client, url: str) -> str:
    return re.search(r'name="id" value="([^"]+)"', client.get(url).text).group(1)


def _patient(client) -> str:
    record_id = _ids(client, "/patients/new")
    r = post_form(client, "/patients/new", {"id": record_id, "given_name": "Wanjiru"}, from_page="/patients/new")
    assert r.status_code == 303, r.text[:500]
    return record_id


def test_an_injury_time_in_the_future_comes_back_on_the_form_then_saves_in_utc(nairobi):
    client, services = nairobi
    patient_id = _patient(client)
    url = f"/patients/{patient_id}/encounters/new"
    page = client.get(url).text
    assert "Time of injury (Africa/Nairobi, UTC+03:00)" in page
    assert "Up to 5 minutes ahead of the clinic clock is accepted." in page
    assert re.search(r'<option value="[^"]+" selected>', page) is None, "the mode is the clinician's choice"
    record_id = _ids(client, url)
    wall = dt.datetime.now(NAIROBI).replace(second=0, microsecond=0, tzinfo=None)
    typed = {
        "id": record_id,
        "mode": "emergency",
        "time_of_arrival": (wall + dt.timedelta(hours=2)).strftime("%Y-%m-%dT%H:%M"),
        "time_of_injury": (wall + dt.timedelta(hours=1)).strftime("%Y-%m-%dT%H:%M"),
        "clinician": "Dr Otieno",
    }
    r = post_form(client, url, typed)
    assert r.status_code == 422
    assert f'value="{typed["time_of_injury"]}"' in r.text and 'value="Dr Otieno"' in r.text
    assert 'id="field-time_of_arrival-error"' in r.text and "is in the future" in r.text
    assert '<option value="emergency" selected>' in r.text
    assert 'href="#field-time_of_arrival"' in r.text, "the error summary links to the field"
    principal = services.accounts.authenticate(client.cookies["burnedge_session"])
    assert services.records.list_records(principal, RecordKind.encounter) == []

    # Within the tolerance (a phone's clock a little fast) it is accepted, and stored as the instant in UTC.
    typed |= {
        "time_of_arrival": (wall + dt.timedelta(minutes=2)).strftime("%Y-%m-%dT%H:%M"),
        "time_of_injury": (wall - dt.timedelta(hours=1)).strftime("%Y-%m-%dT%H:%M"),
    }
    r = post_form(client, url, typed)
    assert r.status_code == 303, r.text[-2000:]
    stored = services.records.get(principal, RecordKind.encounter, record_id).data
    injury = dt.datetime.fromisoformat(stored["time_of_injury"])
    assert injury.utcoffset() == dt.timedelta(0)
    assert injury.astimezone(NAIROBI).replace(tzinfo=None) == wall - dt.timedelta(hours=1)
    page = client.get(f"/encounters/{record_id}").text
    assert (wall - dt.timedelta(hours=1)).strftime("%Y-%m-%d %H:%M") in page, "shown again in clinic time"


def test_a_service_refusal_lands_on_its_field_on_every_new_record_form(nairobi):
    client, services = nairobi
    record_id = _ids(client, "/patients/new")
    born = (dt.date.today() + dt.timedelta(days=30)).isoformat()
    r = post_form(client, "/patients/new", {"id": record_id, "given_name": "Baraka", "date_of_birth": born})
    assert r.status_code == 422 and 'value="Baraka"' in r.text
    assert 'id="field-date_of_birth-error"' in r.text and "date of birth is in the future" in r.text
    patient_id = _patient(client)
    url = f"/patients/{patient_id}/encounters/new"
    typed = {"id": _ids(client, url), "mode": "consultation"}
    typed |= {"time_of_arrival": "2026-01-10T08:00", "time_of_injury": "2026-01-10T09:00"}
    r = post_form(client, url, typed)
    assert r.status_code == 422 and 'id="field-time_of_injury-error"' in r.text
    assert "the time of injury is after the time of arrival" in r.text


def test_a_survey_time_ahead_of_the_clinic_clock_is_named_beside_its_field(nairobi):
    client, _ = nairobi
    patient_id = _patient(client)
    url = f"/patients/{patient_id}/encounters/new"
    typed = {"id": _ids(client, url), "mode": "emergency", "time_of_arrival": "2026-01-10T08:00"}
    assert post_form(client, url, typed).status_code == 303
    part = f"/encounters/{typed['id']}/parts/primary-survey"
    form = client.get(part).text
    assert "Assessed at (Africa/Nairobi, UTC+03:00)" in form
    ahead = (dt.datetime.now(NAIROBI) + dt.timedelta(minutes=30)).strftime("%Y-%m-%dT%H:%M")
    r = post_form(client, part, {"version": "0", "assessed_at": ahead, "breathing.spo2_percent": "94"})
    assert r.status_code == 422 and f'value="{ahead}"' in r.text and 'value="94"' in r.text
    assert 'id="field-assessed_at-error"' in r.text and "ahead of the clinic clock" in r.text
