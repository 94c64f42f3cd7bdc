"""Browser forms from the schemas: a record rendered, posted back as a browser would and parsed is the same record;
bad input names every bad field, in plain words, and the form comes back with what was typed.

The browser is simulated from the rendered HTML itself (tests/page_forms_helpers.py).
"""

from __future__ import annotations

import datetime as dt
import zoneinfo

import msgspec
import pytest

from base.web.pages.forms import FormInvalid, field_errors, form_fields, parse_form
from base.web.pages.forms_spec import label_for
from schemas.burn_chart import BurnChart
from schemas.patient import Encounter, Patient
from schemas.problem import FieldProblem
from schemas.record_parts import Intake, Mechanism, PrimarySurvey, Resuscitation, SecondarySurvey
from tests.page_forms_helpers import EAT, EID, IDS, PID, RECORDS, T0, Browser, edited, fixed_ids, flat, post, render


def form_errors(struct_type: type, raw, *, fixed: dict) -> dict[str, str]:
    """The messages by input name of a form that must not parse (it fails the test if it does)."""
    with pytest.raises(FormInvalid) as caught:
        parse_form(struct_type, raw, fixed=fixed)
    return field_errors(caught.value.errors)


@pytest.mark.parametrize("tz", [None, EAT, zoneinfo.ZoneInfo("America/New_York")], ids=["local", "eat", "ny"])
@pytest.mark.parametrize("key", RECORDS)
def test_a_record_posted_back_unchanged_is_the_same_record(key, tz):
    record = RECORDS[key]
    fixed = fixed_ids(record)
    fields = form_fields(type(record), value=record, skip=fixed, tz=tz)
    parsed = parse_form(type(record), post(fields), fixed=fixed, tz=tz)
    assert parsed == record  # aware datetimes compare as instants


@pytest.mark.parametrize("key", RECORDS)
def test_every_control_has_a_label_and_its_notes(key):
    record = RECORDS[key]
    errors = {f.name: "check this" for f in flat(form_fields(type(record), value=record, skip=fixed_ids(record)))}
    html = render(form_fields(type(record), value=record, skip=fixed_ids(record), errors=errors))
    page = Browser(html)
    assert len(page.ids) == len(set(page.ids))
    for control in page.controls:
        assert control["id"] in page.label_for, control
        assert control.get("aria-invalid") == "true", control
    for control in page.controls:
        for ref in control.get("aria-describedby", "").split():
            assert ref in page.ids
    assert "style=" not in html and "<script" not in html


def test_new_forms_posted_as_shown_keep_the_defaults_and_drop_blank_rows():
    for struct_type in (Intake, Resuscitation, SecondarySurvey, BurnChart):
        fields = form_fields(struct_type, skip=IDS)
        fixed = {"encounter_id": EID} | ({"assessed_at": T0} if struct_type in (SecondarySurvey, BurnChart) else {})
        assert parse_form(struct_type, post(fields), fixed=fixed) == struct_type(**fixed)
    assert form_errors(Mechanism, post(form_fields(Mechanism, skip=IDS)), fixed={"encounter_id": EID}) == {
        "type": "is required"
    }


def test_fields_carry_the_schema_limits_labels_and_help():
    by_name = {f.name: f for f in flat(form_fields(PrimarySurvey, skip=IDS))}
    spo2 = by_name["breathing.spo2_percent"]
    assert (spo2.label, spo2.kind, spo2.min, spo2.max, spo2.step) == ("SpO2 (%)", "number", "0", "100", "1")
    assert by_name["breathing.oxygen_l_per_min"].step == "any"
    assert by_name["airway.patent"].kind == "tristate" and by_name["airway.facial_burns"].kind == "checkbox"
    assert by_name["airway"].kind == "group" and by_name["assessed_at"].kind == "datetime"
    assert by_name["pain_poorly_controlled"].help.startswith("Pain not controlled")
    patient = {f.name: f for f in form_fields(Patient, skip=IDS)}
    assert patient["weight_source"].choices[0] == ("", "Not recorded")
    assert patient["date_of_birth"].kind == "date" and patient["given_name"].maxlength == 200
    mechanism = {f.name: f for f in form_fields(Mechanism, skip=IDS)}
    assert mechanism["type"].required and mechanism["type"].choices[0] == ("", "Choose one")
    assert mechanism["description"].kind == "textarea"
    intake = {f.name: f for f in form_fields(Intake, skip=IDS, blank_rows=1)}
    assert intake["medications"].kind == "list" and len(intake["medications"].rows) == 1
    assert not any(f.required for f in intake["medications"].rows[0]), "a blank row must not block the form"
    assert label_for("systolic_bp_mmhg") == "Systolic BP (mmHg)" and label_for("temperature_c") == "Temperature (°C)"
    assert label_for("blood_glucose_mmol_l") == "Blood glucose (mmol/L)" and label_for("gcs_eye") == "GCS eye"


def test_datetimes_are_wall_time_in_the_given_zone_or_carry_their_offset():
    fields = {f.name: f for f in form_fields(Encounter, value=RECORDS["encounter"], skip=IDS, tz=EAT)}
    assert fields["time_of_arrival"].value == "2026-03-01T10:15:30" and fields["time_of_arrival"].step == "1"
    assert fields["time_of_injury"].value == "2026-03-01T07:45" and fields["time_of_injury"].step is None
    raw = {"mode": ["emergency"], "time_of_arrival": ["2026-03-01T10:15"], "time_of_injury": ["2026-03-01T06:00Z"]}
    enc = parse_form(Encounter, raw, fixed={"id": EID, "patient_id": PID}, tz=EAT)
    assert enc.time_of_arrival == dt.datetime(2026, 3, 1, 7, 15, tzinfo=dt.UTC)
    assert enc.time_of_injury == dt.datetime(2026, 3, 1, 6, 0, tzinfo=dt.UTC)
    local = parse_form(Encounter, raw, fixed={"id": EID, "patient_id": PID})
    assert local.time_of_arrival == dt.datetime(2026, 3, 1, 10, 15).astimezone()


def test_bad_input_names_every_bad_field_and_nothing_is_built():
    survey = RECORDS["primary-survey"]
    pairs = post(form_fields(PrimarySurvey, value=survey, skip=IDS))
    bad = edited(
        pairs,
        breathing__spo2_percent="150",
        breathing__respiratory_rate_per_min="abc",
        disability__gcs_eye="0",
        circulation__heart_rate_per_min="72.5",
        assessed_at="yesterday",
        airway__intervention="prayer",
    )
    assert form_errors(PrimarySurvey, bad, fixed={"encounter_id": EID}) == {
        "breathing.spo2_percent": "must be at most 100",
        "breathing.respiratory_rate_per_min": "enter a number",
        "disability.gcs_eye": "must be at least 1",
        "circulation.heart_rate_per_min": "enter a whole number",
        "assessed_at": "must be a date and time like 2026-12-03T14:30",
        "airway.intervention": "choose one of the options",
    }
    patient = edited(post(form_fields(Patient, skip=IDS)), weight_kg="abc", height_cm="300", date_of_birth="3/12/26")
    assert form_errors(Patient, patient, fixed={"id": PID}) == {
        "weight_kg": "enter a number",
        "height_cm": "must be at most 272",
        "date_of_birth": "must be a date like 2026-12-03",
    }
    mechanism = edited(post(form_fields(Mechanism, skip=IDS)), description="x" * 20_001, duration_s="-1")
    assert form_errors(Mechanism, mechanism, fixed={"encounter_id": EID}) == {
        "type": "is required",
        "description": "at most 20000 characters (this has 20001)",
        "duration_s": "must be at least 0",
    }


def test_the_form_comes_back_with_what_was_typed_and_the_messages():
    raw = {"medications[0].name": [""], "medications[1].dose": ["5 mg"], "medications[2].name": ["aspirin"]}
    raw |= {"past_medical_history": ["<script>alert(1)</script>"], "years_since_last_tetanus_dose": ["lots"]}
    errors = form_errors(Intake, raw, fixed={"encounter_id": EID})
    assert errors == {"medications[0].name": "is required", "years_since_last_tetanus_dose": "enter a number"}
    fields = form_fields(Intake, raw=raw, errors=errors, skip=IDS, blank_rows=1)
    by_name = {f.name: f for f in flat(fields)}
    assert by_name["years_since_last_tetanus_dose"].value == "lots"
    assert by_name["medications[0].dose"].value == "5 mg" and by_name["medications[0].name"].error == "is required"
    assert by_name["medications[1].name"].value == "aspirin" and "medications[3].name" not in by_name
    html = render(fields)
    assert "<script>" not in html and "&lt;script&gt;alert(1)&lt;/script&gt;" in html
    assert 'id="field-medications-0-name-error"' in html and 'aria-invalid="true"' in html
    assert 'href="#field-medications-0-name">Medication 1: Name: is required' in html


def test_service_errors_in_json_paths_land_on_their_inputs():
    problems = [
        FieldProblem(field="$.last_tetanus_dose", message="the last tetanus dose is dated in the future"),
        FieldProblem(field="$.medications[1].name", message="check the name"),
        FieldProblem(field="$.medications[0]", message="Object missing required field `name`"),
        FieldProblem(field="$.breathing.spo2_percent", message="Expected `int` <= 100"),
        FieldProblem(field="$", message="the encounter was withdrawn"),
    ]
    errors = field_errors(problems)
    assert errors == {
        "last_tetanus_dose": "the last tetanus dose is dated in the future",
        "medications[1].name": "check the name",
        "medications[0].name": "is required",
        "breathing.spo2_percent": "must be at most 100",
        "": "the encounter was withdrawn",
    }
    fields = form_fields(Intake, value=RECORDS["intake"], errors=errors, skip=IDS)
    html = render(fields, general=errors[""])
    assert "the last tetanus dose is dated in the future" in html and "the encounter was withdrawn" in html


def test_what_msgspec_alone_catches_is_named_too():
    assert form_errors(Patient, {}, fixed={"id": "not-an-id"}) == {"id": "is not in the expected form"}


def test_markup_typed_into_a_field_is_shown_as_text_and_stored_as_typed():
    record = msgspec.structs.replace(RECORDS["patient"], given_name="<script>alert(1)</script>")
    fields = form_fields(Patient, value=record, skip=IDS, errors={"family_name": "<b>bold</b>"})
    html = render(fields)
    assert "<script>" not in html and "<b>" not in html
    assert 'value="&lt;script&gt;alert(1)&lt;/script&gt;"' in html
    assert parse_form(Patient, post(fields), fixed={"id": PID}) == record


def test_the_page_hidden_inputs_are_ignored_and_other_unknown_inputs_named():
    record = RECORDS["mechanism"]
    pairs = post(form_fields(Mechanism, value=record, skip=IDS))
    sent = edited(pairs, csrf_token="abc123", version="3", encounter_id="not-read")
    assert parse_form(Mechanism, sent, fixed=fixed_ids(record)) == record
    typo = edited(pairs, agnet="kettle", **{"entries[0].region": "head_anterior", "breathing.spo2_percent": "90"})
    assert form_errors(Mechanism, edited(typo, duration_s="soon"), fixed=fixed_ids(record)) == {
        "agnet": "unknown field",
        "entries[0].region": "unknown field",
        "breathing.spo2_percent": "unknown field",
        "duration_s": "enter a number",
    }


def test_a_burn_chart_row_names_its_bad_inputs_and_blank_rows_are_dropped():
    chart = RECORDS["burn-chart"]
    fields = form_fields(BurnChart, value=chart, skip=IDS, blank_rows=2)
    entries = {f.name: f for f in fields}["entries"]
    assert len(entries.rows) == len(chart.entries) + 2
    row = {f.name: f for f in entries.rows[0]}
    assert row["entries[0].fraction"].min == "0" and row["entries[0].fraction"].max == "1"
    assert row["entries[0].region"].kind == "select" and row["entries[0].circumferential"].kind == "checkbox"
    typed = {"entries[1].fraction": "1.5", "entries[2].depth": "", "entries[3].region": "neck_anterior"}
    bad = edited(post(fields), **typed)
    assert form_errors(BurnChart, bad, fixed={"encounter_id": EID}) == {
        "entries[1].fraction": "must be at most 1",
        "entries[2].depth": "is required",
        "entries[3].fraction": "is required",
        "entries[3].depth": "is required",
    }
    shown = {
        f.name: f
        for f in flat(form_fields(BurnChart, raw=bad, errors=form_errors(BurnChart, bad, fixed={"encounter_id": EID})))
    }
    assert shown["entries[1].fraction"].value == "1.5" and shown["entries[3].region"].value == "neck_anterior"
    assert shown["entries[2].depth"].error == "is required"
