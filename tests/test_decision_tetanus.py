"""Tetanus prophylaxis against the CDC/ACIP wound-management table, cell by cell, and as read from the intake."""

from __future__ import annotations

import datetime as dt

import pytest

from processing.clinical import tetanus
from processing.clinical.decision_inputs import DecisionInputs
from processing.clinical.tetanus import Wound, table_cell
from schemas.clinical_results import InputRef
from schemas.encounter_snapshot import Versioned
from schemas.ids import uuid7
from schemas.patient import Encounter, EncounterMode, Patient
from schemas.record_parts import Intake, TetanusDoses, TetanusStatus

INJURY = dt.datetime(2026, 11, 30, 9, 0, tzinfo=dt.UTC)

# (doses, years since the last dose, wound) -> (vaccine, TIG), as printed in the table.
TABLE = [
    (TetanusDoses.unknown, None, Wound.clean_minor, True, False),
    (TetanusDoses.fewer_than_three, 2.0, Wound.clean_minor, True, False),
    (TetanusDoses.unknown, None, Wound.other, True, True),
    (TetanusDoses.fewer_than_three, 1.0, Wound.other, True, True),
    (TetanusDoses.three_or_more, 9.9, Wound.clean_minor, False, False),
    (TetanusDoses.three_or_more, 10.0, Wound.clean_minor, True, False),
    (TetanusDoses.three_or_more, 4.9, Wound.other, False, False),
    (TetanusDoses.three_or_more, 5.0, Wound.other, True, False),
]


@pytest.mark.parametrize(("doses", "years", "wound", "vaccine", "tig"), TABLE)
def test_every_cell_of_the_table(doses, years, wound, vaccine, tig):
    cell = table_cell(doses, years, wound)
    assert (cell.vaccine, cell.tig) == (vaccine, tig)


def test_three_doses_without_the_time_of_the_last_cannot_be_decided():
    cell = table_cell(TetanusDoses.three_or_more, None, Wound.other)
    assert cell.vaccine is None and cell.tig is False


def _inputs(age_years: float | None = 34.0, **intake) -> DecisionInputs:
    patient = Patient(id=uuid7())
    encounter = Encounter(
        id=uuid7(),
        patient_id=patient.id,
        mode=EncounterMode.emergency,
        time_of_arrival=INJURY + dt.timedelta(hours=1),
        time_of_injury=INJURY,
    )
    part = Intake(encounter_id=encounter.id, **intake) if intake else None
    return DecisionInputs(
        patient=Versioned(patient, InputRef(kind="patient", id=patient.id, version=1)),
        encounter=Versioned(encounter, InputRef(kind="encounter", id=encounter.id, version=1)),
        intake=Versioned(part, InputRef(kind="intake", id=encounter.id, version=3)) if part else None,
        as_of=INJURY + dt.timedelta(hours=2),
        age_years=age_years,
    )


def _one(inputs: DecisionInputs):
    (recommendation,), missing = tetanus.recommend(inputs)
    return recommendation, missing


def test_a_burn_with_three_doses_and_a_dose_six_years_ago_needs_a_booster_and_no_tig():
    r, missing = _one(_inputs(tetanus_doses=TetanusDoses.three_or_more, last_tetanus_dose=dt.date(2020, 11, 1)))
    assert "give Tdap (or Td" in r.text and "immune globulin is not indicated" in r.text
    assert not r.urgent and missing == []
    assert {(i.name, i.value, i.version) for i in r.inputs} >= {
        ("prior tetanus doses", "three_or_more", 3),
        ("last tetanus dose", "2020-11-01", 3),
    }


def test_a_burn_with_three_doses_four_years_ago_needs_nothing():
    r, _ = _one(_inputs(tetanus_doses=TetanusDoses.three_or_more, years_since_last_tetanus_dose=4.0))
    assert r.text.startswith("Tetanus: no vaccine needed now")
    assert "immune globulin is not indicated" in r.text


def test_no_intake_counts_as_unknown_doses_and_gives_vaccine_and_tig():
    r, missing = _one(_inputs())
    assert "give Tdap (or Td" in r.text and "Give tetanus immune globulin" in r.text and r.urgent
    assert r.details == [tetanus.TIG_DOSE]
    assert missing and "intake not recorded" in missing[0]


@pytest.mark.parametrize(
    ("age", "doses", "vaccine"),
    [
        (3.0, TetanusDoses.fewer_than_three, "DTaP (under 7 years)"),
        (8.0, TetanusDoses.fewer_than_three, "Tdap (or Td if Tdap was given before)"),
        (8.0, TetanusDoses.three_or_more, "give Td or Tdap"),
        (29.0, TetanusDoses.three_or_more, "Tdap (or Td if Tdap was given before)"),
        (None, TetanusDoses.fewer_than_three, "age not recorded"),
    ],
)
def test_the_vaccine_named_follows_the_age(age, doses, vaccine):
    r, _ = _one(_inputs(age_years=age, tetanus_doses=doses, years_since_last_tetanus_dose=6.0))
    assert vaccine in r.text


def test_severe_immunodeficiency_gives_tig_whatever_the_doses():
    r, _ = _one(
        _inputs(
            tetanus_doses=TetanusDoses.three_or_more, years_since_last_tetanus_dose=1.0, severe_immunodeficiency=True
        )
    )
    assert "Give tetanus immune globulin (severe immunodeficiency" in r.text and r.urgent


def test_three_doses_with_the_last_unknown_says_what_to_record():
    r, missing = _one(_inputs(tetanus_doses=TetanusDoses.three_or_more))
    assert "Record the date of the last dose" in r.text
    assert missing and "last tetanus dose" in missing[0]


@pytest.mark.parametrize(
    ("status", "expected"),
    [
        (TetanusStatus.never_immunised, "Give tetanus immune globulin"),
        (TetanusStatus.up_to_date, "no vaccine needed now"),
        (TetanusStatus.not_up_to_date, "Give tetanus immune globulin"),
    ],
)
def test_the_older_status_still_counts_where_the_doses_are_not_recorded(status, expected):
    r, _ = _one(_inputs(tetanus_status=status))
    assert expected in r.text
    if status is not TetanusStatus.not_up_to_date:
        assert any(i.name == "tetanus status (older form)" for i in r.inputs)


def test_a_recorded_date_overrides_the_older_up_to_date_status():
    r, _ = _one(_inputs(tetanus_status=TetanusStatus.up_to_date, last_tetanus_dose=dt.date(2012, 5, 1)))
    # "Up to date" with a dose 14 years before the burn: the dose count is not recorded, so the table's
    # unknown row applies.
    assert "Give tetanus immune globulin" in r.text
