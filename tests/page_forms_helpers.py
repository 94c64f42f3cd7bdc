"""Helpers of tests/test_page_forms.py: realistic records, the fields macro rendered, and a browser simulated from
the rendered HTML itself (html.parser): inputs send their value, checkboxes and radios only when checked, a select
its selected option (or its first), a textarea its text with CRLF line breaks.
"""

from __future__ import annotations

import datetime as dt
from html.parser import HTMLParser

import jinja2
from litestar.datastructures import FormMultiDict

from base.web.pages.forms import errors_in
from harness.processes import REPO
from schemas.burn_chart import (
    AgeAdjustment,
    BurnChart,
    BurnChartEntry,
    BurnDepth,
    LundBrowderRegion,
    SpecialArea,
    SpecialAreaInvolvement,
)
from schemas.ids import uuid7
from schemas.patient import Encounter, EncounterMode, Patient, Sex, WeightSource
from schemas.record_parts import (
    Airway,
    AirwayIntervention,
    Allergy,
    Avpu,
    BodyArea,
    Breathing,
    Circulation,
    Disability,
    Exposure,
    Finding,
    FluidFormula,
    FluidGiven,
    Intake,
    Mechanism,
    MechanismType,
    Medication,
    OtherInjury,
    PrimarySurvey,
    Resuscitation,
    SecondarySurvey,
    SocialContext,
    TetanusDoses,
    TetanusStatus,
)

ENV = jinja2.Environment(
    autoescape=True,
    loader=jinja2.FileSystemLoader(REPO / "base/web/templates"),
    undefined=jinja2.StrictUndefined,
)
PAGE = ENV.from_string(
    '{% from "macros/fields.html" import render_fields, render_error_summary %}'
    "<form>{{ render_error_summary(summary, general) }}{{ render_fields(fields) }}</form>"
)
EAT = dt.timezone(dt.timedelta(hours=3))
T0 = dt.datetime(2026, 3, 1, 7, 15, 30, tzinfo=dt.UTC)
EID, PID = uuid7(), uuid7()


def render(fields, general=None) -> str:
    return PAGE.render(fields=fields, summary=errors_in(fields), general=general)


class Browser(HTMLParser):
    """What a browser would post for a form, and what a checker needs to know about its controls."""

    def __init__(self, html: str):
        super().__init__(convert_charrefs=True)
        self.pairs: list[tuple[str, str]] = []
        self.controls: list[dict] = []
        self.ids: list[str] = []
        self.label_for: set[str] = set()
        self._select: dict | None = None
        self._options: list[dict] = []
        self._textarea: dict | None = None
        self._text: list[str] = []
        self.feed(html)
        self.close()

    def handle_starttag(self, tag, attrs):
        a = {k: v or "" for k, v in attrs}
        self.ids += [a["id"]] if "id" in a else []
        if tag == "label":
            self.label_for.add(a["for"])
        elif tag == "input":
            self.controls.append(a)
            if a.get("type") not in ("checkbox", "radio") or "checked" in a:
                self.pairs.append((a["name"], a.get("value", "on")))
        elif tag == "select":
            self.controls.append(a)
            self._select, self._options = a, []
        elif tag == "option":
            self._options.append(a)
        elif tag == "textarea":
            self.controls.append(a)
            self._textarea, self._text = a, []

    def handle_data(self, data):
        if self._textarea is not None:
            self._text.append(data)

    def handle_endtag(self, tag):
        if tag == "select":
            chosen = [o for o in self._options if "selected" in o] or self._options[:1]
            self.pairs.append((self._select["name"], chosen[0]["value"]))
            self._select = None
        elif tag == "textarea":
            text = "".join(self._text).removeprefix("\n")  # HTML drops the newline right after <textarea>
            self.pairs.append((self._textarea["name"], text.replace("\n", "\r\n")))
            self._textarea = None


def post(fields) -> FormMultiDict:
    return FormMultiDict(Browser(render(fields)).pairs)


def edited(pairs: FormMultiDict, **changes: str) -> FormMultiDict:
    """The posted form with some inputs retyped ("__" in a keyword stands for ".")."""
    out = dict(pairs.multi_items())
    out.update({k.replace("__", "."): v for k, v in changes.items()})
    return FormMultiDict(list(out.items()))


RECORDS = {
    "patient": Patient(
        id=PID,
        given_name="Amina",
        family_name="O'Neil",
        date_of_birth=dt.date(1990, 1, 1),
        sex=Sex.female,
        weight_kg=62.5,
        weight_source=WeightSource.measured,
        height_cm=165.0,
        medical_record_number="MRN-0042",
        pregnant=False,
    ),
    "patient-minimal": Patient(id=PID, age_estimate_years=35.0),
    "encounter": Encounter(
        id=EID,
        patient_id=PID,
        mode=EncounterMode.emergency,
        time_of_arrival=T0,
        time_of_injury=dt.datetime(2026, 3, 1, 7, 45, tzinfo=EAT),
        clinician="Dr. Test",
        weight_kg=70.0,
    ),
    "intake": Intake(
        encounter_id=EID,
        history_of_present_illness="Kettle spill\nwhile cooking.",
        past_medical_history="Asthma",
        significant_comorbidities=["asthma", "diabetes"],
        medications=[Medication(name="salbutamol", dose="100 mcg"), Medication(name="metformin")],
        allergies=[Allergy(substance="penicillin", reaction="rash")],
        tetanus_status=TetanusStatus.not_up_to_date,
        tetanus_doses=TetanusDoses.three_or_more,
        last_tetanus_dose=dt.date(2015, 6, 1),
        severe_immunodeficiency=False,
        social=SocialContext(lives_with="parents", safeguarding_concern=True, notes="Lives\n\nfar away"),
    ),
    "primary-survey": PrimarySurvey(
        encounter_id=EID,
        assessed_at=T0,
        airway=Airway(patent=True, facial_burns=True, intervention=AirwayIntervention.adjunct),
        breathing=Breathing(
            respiratory_rate_per_min=22, spo2_percent=94, oxygen_l_per_min=2.5, carboxyhaemoglobin_percent=3.0
        ),
        circulation=Circulation(heart_rate_per_min=110, systolic_bp_mmhg=120, capillary_refill_s=2.5, iv_access=True),
        disability=Disability(gcs_eye=4, gcs_verbal=5, gcs_motor=6, avpu=Avpu.alert, blood_glucose_mmol_l=5.4),
        exposure=Exposure(temperature_c=36.6, burn_cooled=True, cooling_minutes=20.0, jewellery_removed=False),
        pain_poorly_controlled=True,
    ),
    "secondary-survey": SecondarySurvey(
        encounter_id=EID,
        assessed_at=T0,
        findings=[Finding(area=BodyArea.face, finding="Blistering <left> cheek & chin")],
        other_injuries=[
            OtherInjury(description="Fractured radius", area=BodyArea.upper_limb_left, major=True),
            OtherInjury(description="Abrasion"),
        ],
    ),
    "mechanism": Mechanism(
        encounter_id=EID, type=MechanismType.scald, duration_s=5.0, agent="boiling water", description="Pot tipped"
    ),
    "resuscitation": Resuscitation(
        encounter_id=EID,
        formula=FluidFormula.custom,
        custom_ml_per_kg_per_percent=3.0,
        fluid_given=[
            FluidGiven(volume_ml=500.0, given_at=T0),
            FluidGiven(volume_ml=250.5, given_at=T0 + dt.timedelta(minutes=40), fluid="Normal saline"),
        ],
    ),
    "burn-chart": BurnChart(
        encounter_id=EID,
        assessed_at=T0,
        entries=[
            BurnChartEntry(region=LundBrowderRegion.head_anterior, fraction=0.5, depth=BurnDepth.superficial_partial),
            BurnChartEntry(
                region=LundBrowderRegion.lower_arm_left_anterior,
                fraction=1.0,
                depth=BurnDepth.full_thickness,
                circumferential=True,
            ),
            BurnChartEntry(region=LundBrowderRegion.trunk_anterior, fraction=0.125, depth=BurnDepth.deep_partial),
        ],
        special_areas=[SpecialAreaInvolvement(area=SpecialArea.face, depth=BurnDepth.superficial_partial)],
        age_adjustment=AgeAdjustment.interpolate,
    ),
}
IDS = ("id", "patient_id", "encounter_id")


def fixed_ids(record) -> dict:
    return {k: getattr(record, k) for k in IDS if hasattr(record, k)}


def flat(fields):
    """Every field, depth first, list rows included."""
    for f in fields:
        yield f
        yield from flat(f.children)
        for row in f.rows:
            yield from flat(row)
