"""The encounter's fluids card (issue 38): it names only what the record lacks, never shows a formula rate beside
"not indicated", and gives the oral or maintenance advice in plain words from the stored FluidPlan."""

from __future__ import annotations

import datetime as dt
import re

import pytest

from base.web.pages.fluid_card import (
    FORMULA_ONLY_WARNING_PREFIX,
    MISSING_INJURY_TIME_PREFIX,
    fluid_card,
    fluid_needs,
)
from processing.clinical.assessment import MISSING_INJURY_TIME, assess
from processing.clinical.fluids import TITRATE_WARNING
from schemas.accounts import Role
from schemas.burn_chart import BurnChart, BurnChartEntry, BurnDepth, LundBrowderRegion
from schemas.clinical_results import InputRef
from schemas.config import ClinicalConfig
from schemas.ids import uuid7
from schemas.patient import Encounter, EncounterMode, Patient
from schemas.records import RecordKind
from tests.conftest import make_user
from tests.pages_helpers import post_form, sign_in

NOW = dt.datetime(2026, 3, 1, 12, 0, tzinfo=dt.UTC)
PID, EID = uuid7(), uuid7()


def _assessment(*, weight=70.0, age=30.0, injured=True, percent=50.0, regions=(LundBrowderRegion.trunk_anterior,)):
    patient = Patient(id=PID, age_estimate_years=age, weight_kg=weight)
    encounter = Encounter(
        id=EID,
        patient_id=PID,
        mode=EncounterMode.emergency,
        time_of_arrival=NOW - dt.timedelta(hours=1),
        time_of_injury=NOW - dt.timedelta(hours=2) if injured else None,
    )
    parts, inputs = {}, [InputRef(kind="encounter", id=EID, version=1)]
    if percent:
        entries = [BurnChartEntry(region=r, fraction=percent / 100, depth=BurnDepth.deep_partial) for r in regions]
        parts[RecordKind.burn_chart] = BurnChart(encounter_id=EID, assessed_at=NOW, entries=entries)
        inputs.append(InputRef(kind="burn_chart", id=EID, version=1))
    return assess(
        patient=patient,
        encounter=encounter,
        parts=parts,
        inputs=inputs,
        as_of=NOW,
        config=ClinicalConfig(),
        computed_at=NOW,
        clock_skew_s=300,
    )


def test_the_wording_this_card_matches_is_the_calculators():
    assert MISSING_INJURY_TIME.startswith(MISSING_INJURY_TIME_PREFIX)
    assert TITRATE_WARNING.startswith(FORMULA_ONLY_WARNING_PREFIX)


@pytest.mark.parametrize(
    ("kwargs", "needs"),
    [
        ({"percent": 0}, ["a burn chart"]),
        ({"injured": False}, ["the time of injury"]),
        ({"weight": None}, ["the patient's weight"]),
        (
            {"weight": None, "injured": False, "percent": 0},
            ["the patient's weight", "the time of injury", "a burn chart"],
        ),
        ({"age": None}, ["the patient's age (date of birth or an estimate)"]),
    ],
)
def test_no_plan_names_only_what_is_missing(kwargs, needs):
    assessment = _assessment(**kwargs)
    assert assessment.fluids is None and fluid_needs(assessment) == needs
    card = fluid_card(assessment)
    assert card.value == "—" and card.meta.startswith("No fluid plan yet: record ")
    for word, thing in [("weight", "the patient's weight"), ("time of injury", "the time of injury")]:
        assert (word in card.meta) == (thing in needs)


def test_below_the_threshold_there_is_no_rate_only_oral_advice_and_the_urine_target():
    assessment = _assessment(percent=50.0)  # half the adult anterior trunk: 6.5 %TBSA
    plan = assessment.fluids
    assert plan is not None and not plan.formal_resuscitation_indicated and plan.rate_now_ml_per_h > 0
    card = fluid_card(assessment)
    text = " ".join([card.value, card.meta, *card.advice, *card.warnings])
    assert "mL/h" not in text.replace(card.urine, "").replace("(35–70 mL/h)", ""), text
    assert f"{plan.rate_now_ml_per_h:g}" not in text and "run " not in text
    assert card.value == "Oral fluids" and "not indicated below 20 %TBSA" in card.meta
    assert card.advice == [
        "Formal resuscitation is not usually needed below 20 %TBSA for this patient (this burn: 6.5 %): "
        "encourage oral fluids; watch urine output 0.5–1 mL/kg/h (35–70 mL/h)."
    ]
    assert not any(w.startswith(FORMULA_ONLY_WARNING_PREFIX) for w in card.warnings)


def test_a_small_child_below_the_threshold_gets_the_maintenance_rate():
    assessment = _assessment(weight=12.0, age=2.0, percent=50.0)
    plan = assessment.fluids
    assert plan is not None and not plan.formal_resuscitation_indicated and plan.maintenance is not None
    card = fluid_card(assessment)
    assert card.value == "Maintenance fluid"
    assert f"maintenance {plan.maintenance.ml_per_h:g} mL/h" in card.meta
    assert card.advice[1].startswith(f"Maintenance fluid for this child: {plan.maintenance.ml_per_h:g} mL/h (")
    assert f"{plan.rate_now_ml_per_h:g} mL/h" not in " ".join([card.meta, *card.advice])


def test_above_the_threshold_the_rate_to_run_now_is_the_figure():
    trunk = (LundBrowderRegion.trunk_anterior, LundBrowderRegion.trunk_posterior)
    assessment = _assessment(regions=trunk, percent=100.0)  # 26 %TBSA in an adult
    plan = assessment.fluids
    assert plan.formal_resuscitation_indicated
    card = fluid_card(assessment)
    assert card.value == f"{plan.rate_now_ml_per_h:,.0f} mL/h now" and "Parkland 4 mL/kg/%TBSA, 70 kg" in card.meta
    assert card.advice == [plan.statement] and "first 8 h" in card.meta


def test_the_encounter_page_shows_the_card_as_charted(client, services):
    make_user(services, "cleo", Role.clinician)
    sign_in(client, "cleo")
    new = client.get("/patients/new").text
    patient_id = re.search(r'name="id" value="([^"]+)"', new).group(1)
    typed = {"id": patient_id, "given_name": "Omar", "weight_kg": "70", "age_estimate_years": "30"}
    post_form(client, "/patients/new", typed)
    url = f"/patients/{patient_id}/encounters/new"
    encounter_id = re.search(r'name="id" value="([^"]+)"', client.get(url).text).group(1)
    injured = (dt.datetime.now() - dt.timedelta(hours=2)).strftime("%Y-%m-%dT%H:%M")
    typed = {"id": encounter_id, "mode": "emergency", "time_of_arrival": injured, "time_of_injury": injured}
    assert post_form(client, url, typed).status_code == 303
    page = client.get(f"/encounters/{encounter_id}").text
    figure = re.search(r'<div class="figure" id="fluid-figure">.*?</div>', page, re.S).group(0)
    assert "record a burn chart." in figure and "weight" not in figure and "time of injury" not in figure
    chart = f"/encounters/{encounter_id}/burn-chart"
    r = post_form(
        client, chart + "/regions/trunk_anterior", {"version": "0", "deep_partial_percent": "50"}, from_page=chart
    )
    assert r.status_code == 303
    page = client.get(f"/encounters/{encounter_id}").text
    figure = re.search(r'<div class="figure" id="fluid-figure">.*?</div>', page, re.S).group(0)
    advice = re.search(r'<div id="fluid-advice">.*?</div>', page, re.S).group(0)
    assert "Oral fluids" in figure and "not indicated" in figure and "mL/h" not in figure
    assert "encourage oral fluids" in advice and "run " not in advice and "for the next" not in advice
