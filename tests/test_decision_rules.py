"""Pain, wound care, infection and follow-up rules against the figures of the sources they cite."""

from __future__ import annotations

import dataclasses
import datetime as dt

import msgspec
import pytest

from processing.clinical import decision_support, follow_up, infection, pain, wound_care
from schemas.burn_chart import BurnChart, BurnChartEntry, BurnDepth, LundBrowderRegion
from schemas.clinical_results import InputRef
from schemas.decision_support import RecommendationAct, RecommendationState
from schemas.encounter_snapshot import Versioned
from schemas.errors import InvalidInput
from schemas.record_parts import Allergy, Exposure, PrimarySurvey
from tests.test_decision_tetanus import INJURY, _inputs


def _with(inputs, *, hours: float = 2.0, weight: float | None = None, **parts):
    patient = msgspec.structs.replace(inputs.patient.value, weight_kg=weight)
    extra = {k: Versioned(v, InputRef(kind=k, id=inputs.encounter.value.id, version=1)) for k, v in parts.items()}
    return dataclasses.replace(
        inputs,
        patient=Versioned(patient, inputs.patient.ref),
        as_of=INJURY + dt.timedelta(hours=hours),
        **extra,
    )


def _text(recommendations, key):
    return next(r for r in recommendations if r.key == key).text


@pytest.mark.parametrize(
    ("age", "weight", "expected"),
    [
        (6.0, 18.0, "paracetamol 270 mg by mouth 4-6 hourly (15 mg/kg × 18 kg); at most 1080 mg in 24 hours"),
        (15.0, 80.0, "paracetamol 1000 mg by mouth 4-6 hourly (15 mg/kg × 80 kg (capped at 1 g)); at most 4000 mg"),
        (6.0, None, "no dose shown: the child's weight is not recorded"),
        (0.1, 5.0, "infant under 3 months: paracetamol only on a doctor's advice"),
        (40.0, 70.0, "paracetamol 500 mg to 1 g by mouth, at least 4 hours apart; at most 4 g in 24 hours"),
        (40.0, 45.0, "no dose shown: the weight is under 50 kg"),
        (None, 70.0, "no dose shown: the age is not recorded"),
    ],
)
def test_paracetamol_doses_are_capped_at_the_sources_maximum(age, weight, expected):
    made, missing = pain.recommend(_with(_inputs(age_years=age), weight=weight))
    assert expected in _text(made, "pain.paracetamol")
    assert bool(missing) == (weight is None)


def test_a_recorded_allergy_blocks_the_drug_with_the_reason():
    inputs = _inputs(age_years=6.0, allergies=[Allergy(substance="Paracetamol", reaction="urticaria")])
    made, _ = pain.recommend(_with(inputs, weight=18.0))
    text = _text(made, "pain.paracetamol")
    assert "not advised: allergy recorded to Paracetamol (urticaria)" in text and "mg" not in text


@pytest.mark.parametrize(
    ("age", "weight", "expected"),
    [
        (6.0, 20.0, "fentanyl 30 mcg (1.5 mcg/kg × 20 kg)"),
        (14.0, 60.0, "fentanyl 75 mcg (1.5 mcg/kg × 60 kg (capped at 75 mcg))"),
        (0.5, 8.0, "under 12 months: intranasal fentanyl is contraindicated"),
        (6.0, None, "no dose shown"),
    ],
)
def test_intranasal_fentanyl_for_a_child_in_uncontrolled_pain(age, weight, expected):
    inputs = _inputs(age_years=age)
    primary = PrimarySurvey(encounter_id=inputs.encounter.value.id, assessed_at=INJURY, pain_poorly_controlled=True)
    made, _ = pain.recommend(_with(inputs, weight=weight, primary=primary))
    assert expected in _text(made, "pain.fentanyl_intranasal")
    calm, _ = pain.recommend(_with(inputs, weight=weight))
    assert [r.key for r in calm] == ["pain.paracetamol"]


def _chart(inputs) -> BurnChart:
    entry = BurnChartEntry(region=LundBrowderRegion.trunk_anterior, fraction=0.1, depth=BurnDepth.superficial_partial)
    return BurnChart(encounter_id=inputs.encounter.value.id, assessed_at=INJURY, entries=[entry])


@pytest.mark.parametrize(
    ("hours", "cooled_min", "shown"), [(1.0, None, True), (2.9, 10, True), (3.0, None, False), (1.0, 20, False)]
)
def test_cooling_is_advised_only_within_3_hours_and_until_20_minutes_are_recorded(hours, cooled_min, shown):
    inputs = _inputs()
    exposure = Exposure(burn_cooled=cooled_min is not None, cooling_minutes=cooled_min)
    primary = PrimarySurvey(encounter_id=inputs.encounter.value.id, assessed_at=INJURY, exposure=exposure)
    made, _ = wound_care.recommend(_with(inputs, hours=hours, primary=primary))
    assert bool(made) == shown
    if shown:
        assert "until 12:00 UTC" in made[0].text and made[0].urgent  # injury 09:00 UTC


def test_infection_advice_says_no_prophylactic_antibiotics_and_tss_for_children():
    child = _inputs(age_years=4.0)
    made, _ = infection.recommend(_with(child, chart=_chart(child)))
    assert [r.key for r in made] == ["infection.antibiotics", "infection.toxic_shock"]
    assert "not recommended" in made[0].text and "38.9 °C" in made[1].text
    adult = _inputs(age_years=40.0)
    assert [r.key for r in infection.recommend(_with(adult, chart=_chart(adult)))[0]] == ["infection.antibiotics"]


@pytest.mark.parametrize(("hours", "keys"), [(2.0, 2), (4 * 24.0, 2), (5 * 24.0, 1)])
def test_follow_up_dates_count_from_the_injury(hours, keys):
    inputs = _inputs()
    made, _ = follow_up.timing(_with(inputs, hours=hours, chart=_chart(inputs)))
    assert len(made) == keys
    assert "by 2026-12-14" in _text(made, "follow_up.not_healed_2_weeks")  # 14 days after 2026-11-30
    if keys == 2:
        assert "by 2026-12-02 09:00 UTC" in _text(made, "follow_up.depth_reassessment")


def test_an_act_is_kept_while_the_advice_holds_and_reset_when_it_changes():
    inputs = _inputs(age_years=40.0)
    first = decision_support.recommend(_with(inputs, chart=_chart(inputs)), computed_at=INJURY)
    act = RecommendationAct(key="infection.antibiotics", state="declined", reason="cellulitis on arrival")
    acted = decision_support.apply_act(first, act, "dr.a", INJURY)
    again = decision_support.carry_over(acted, decision_support.recommend(_with(inputs, chart=_chart(inputs)), INJURY))
    kept = next(r for r in again.recommendations if r.key == "infection.antibiotics")
    assert (kept.state, kept.reason) == (RecommendationState.declined, "cellulitis on arrival")
    later = decision_support.recommend(_with(inputs, hours=6 * 24.0, chart=_chart(inputs)), INJURY)
    assert "follow_up.depth_reassessment" not in [r.key for r in later.recommendations]
    with pytest.raises(InvalidInput, match="reason"):
        decision_support.apply_act(first, RecommendationAct(key="tetanus", state="declined"), "dr.a", INJURY)


@pytest.mark.parametrize(
    ("depths", "expected"),
    [
        ([BurnDepth.superficial], "simple moisturiser"),
        ([BurnDepth.superficial, BurnDepth.superficial_partial], "paraffin gauze or a silicone dressing"),
        ([BurnDepth.superficial_partial, BurnDepth.deep_partial], "no dressing class is given here"),
        ([BurnDepth.full_thickness], "no dressing class is given here"),
    ],
)
def test_the_dressing_follows_the_deepest_depth_the_clinician_charted(depths, expected):
    inputs = _inputs()
    regions = [LundBrowderRegion.trunk_anterior, LundBrowderRegion.lower_arm_left_anterior]
    entries = [BurnChartEntry(region=r, fraction=0.2, depth=d) for r, d in zip(regions, depths, strict=False)]
    chart = BurnChart(encounter_id=inputs.encounter.value.id, assessed_at=INJURY, entries=entries)
    made, _ = wound_care.recommend(_with(inputs, hours=30.0, chart=chart))
    assert expected in _text(made, "wound_care.dressing")
    assert ("wound_care.elevation" in [r.key for r in made]) == (len(depths) > 1)  # the second entry is a forearm
