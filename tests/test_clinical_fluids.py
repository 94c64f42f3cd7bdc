"""Burn fluid plans (Parkland / ABLS 2018), child maintenance and urine targets: worked examples."""

from __future__ import annotations

import datetime as dt

import pytest

from processing.clinical import fluids
from processing.clinical.fluids import fluid_plan, maintenance_fluid, urine_output_target, validate_resuscitation
from schemas.clinical_results import FluidPhase
from schemas.config import ClinicalConfig
from schemas.errors import InvalidInput
from schemas.record_parts import FluidFormula, FluidGiven, Resuscitation
from schemas.record_parts import MechanismType as M

UTC = dt.UTC
EID = "0192f3b4-6a8e-7c3d-9b1a-000000000002"
INJURY = dt.datetime(2024, 3, 1, 6, 0, tzinfo=UTC)
CONFIG = ClinicalConfig()


def hours(h: float) -> dt.datetime:
    return INJURY + dt.timedelta(hours=h)


def given(*volumes_at: tuple[float, float]) -> list[FluidGiven]:
    return [FluidGiven(volume_ml=v, given_at=hours(h)) for v, h in volumes_at]


def plan(**overrides):
    args = dict(
        weight_kg=70,
        tbsa_percent=40,
        age_years=35,
        mechanism=M.flame,
        time_of_injury=INJURY,
        as_of=INJURY,
        fluid_given=[],
        formula=FluidFormula.parkland,
        custom_ml_per_kg_per_percent=None,
        config=CONFIG,
        clock_skew_s=300,
        weight_source="measured, encounter",
    )
    args.update(overrides)
    return fluid_plan(**args)


def test_parkland_70kg_40_percent_at_injury_time():
    # 4 x 70 x 40 = 11,200 mL: 5,600 over 8 h (700 mL/h), 5,600 over 16 h (350 mL/h)
    p = plan()
    assert p.total_24h_ml == 11_200
    assert p.first_8h_ml == 5_600 and p.next_16h_ml == 5_600
    assert p.nominal_rate_first_8h_ml_per_h == 700
    assert p.nominal_rate_next_16h_ml_per_h == 350
    assert p.rate_now_ml_per_h == 700
    assert p.phase is FluidPhase.first_8h
    assert p.hours_left_in_phase == 8
    assert p.ml_per_kg_per_percent == 4
    assert p.multiplier_basis == "Parkland 4 mL/kg/%TBSA"
    assert p.formal_resuscitation_indicated
    assert p.maintenance is None


def test_clock_runs_from_injury_not_arrival():
    # arrives 3 h after injury, nothing given: 5,600 mL over the 5 h left = 1,120 mL/h
    p = plan(as_of=hours(3))
    assert p.rate_now_ml_per_h == 1_120
    assert p.hours_since_injury == 3
    assert p.hours_left_in_phase == 5


def test_fluid_already_given_is_subtracted():
    # 3 h after injury, 1,000 mL given: (5,600 - 1,000) / 5 = 920 mL/h
    p = plan(as_of=hours(3), fluid_given=given((1_000, 2)))
    assert p.fluid_given_ml == 1_000
    assert p.remaining_in_phase_ml == 4_600
    assert p.rate_now_ml_per_h == 920


def test_fluid_recorded_after_as_of_is_not_counted():
    p = plan(as_of=hours(3), fluid_given=given((1_000, 2), (500, 4)))
    assert p.fluid_given_ml == 1_000
    assert p.rate_now_ml_per_h == 920
    assert any("not counted" in w for w in p.warnings)


def test_second_phase_rate():
    # 10 h after injury, 5,600 given: (11,200 - 5,600) / 14 h = 400 mL/h
    p = plan(as_of=hours(10), fluid_given=given((5_600, 7)))
    assert p.phase is FluidPhase.next_16h
    assert p.rate_now_ml_per_h == 400
    assert p.hours_left_in_phase == 14
    assert not any("first-8-hour volume" in w for w in p.warnings)


def test_second_phase_behind_warns_not_to_bolus():
    # 10 h, 3,000 given: (11,200 - 3,000) / 14 = 585.71 mL/h
    p = plan(as_of=hours(10), fluid_given=given((3_000, 5)))
    assert p.rate_now_ml_per_h == 585.7
    assert any("first-8-hour volume" in w and "do not bolus" in w for w in p.warnings)


def test_over_resuscitation_warning():
    # 4 h, 6,000 given > 5,600 first-8-h volume
    p = plan(as_of=hours(4), fluid_given=given((6_000, 3)))
    assert p.remaining_in_phase_ml == 0
    assert p.rate_now_ml_per_h == 0
    assert any("fluid creep" in w for w in p.warnings)


def test_formula_period_over_after_24_hours():
    p = plan(as_of=hours(25))
    assert p.phase is FluidPhase.complete
    assert p.rate_now_ml_per_h == 0
    assert "24-hour formula period is over" in p.statement


def test_titrate_warning_always_present():
    for p in (plan(), plan(as_of=hours(12)), plan(tbsa_percent=5)):
        assert any("titrate" in w and "urine output" in w for w in p.warnings)
        assert "titrate hourly to urine output" in p.statement


def test_abls_adult_thermal():
    # 2 x 80 x 50 = 8,000 mL; 4,000 / 8 = 500 mL/h
    p = plan(weight_kg=80, tbsa_percent=50, formula=FluidFormula.abls)
    assert p.total_24h_ml == 8_000
    assert p.rate_now_ml_per_h == 500
    assert p.multiplier_basis == "ABLS 2018: 2 mL/kg/%TBSA, adult thermal burn"


def test_abls_child_with_maintenance():
    # 3 x 20 x 30 = 1,800 mL; 900 / 8 = 112.5 mL/h, plus maintenance 4x10 + 2x10 = 60 mL/h
    p = plan(weight_kg=20, tbsa_percent=30, age_years=6, mechanism=M.scald, formula=FluidFormula.abls)
    assert p.ml_per_kg_per_percent == 3
    assert p.total_24h_ml == 1_800
    assert p.rate_now_ml_per_h == 112.5
    assert p.maintenance.ml_per_h == 60
    assert "child" in p.multiplier_basis


def test_abls_light_16_year_old_is_not_a_child_by_age():
    # 16 years old, 25 kg: ABLS children are <= 14 years, so 2 x 25 x 20 = 1,000 mL; past childhood
    # by age, so no child maintenance and the adult urine target 0.5 x 25 = 12.5 mL/h
    p = plan(weight_kg=25, tbsa_percent=20, age_years=16, formula=FluidFormula.abls)
    assert p.ml_per_kg_per_percent == 2
    assert p.total_24h_ml == 1_000
    assert p.maintenance is None
    assert p.urine_output_target.ml_per_h_low == 12.5
    assert p.formal_resuscitation_threshold_percent == 20


@pytest.mark.parametrize("mechanism", [M.electrical_high_voltage, M.lightning])
def test_abls_high_voltage_uses_4ml(mechanism):
    # 4 x 70 x 20 = 5,600 mL
    p = plan(tbsa_percent=20, mechanism=mechanism, formula=FluidFormula.abls)
    assert p.ml_per_kg_per_percent == 4
    assert p.total_24h_ml == 5_600
    assert p.urine_output_target.ml_per_h_low == 70  # 1.0 mL/kg/h
    assert p.urine_output_target.ml_per_h_high == 105  # 1.5 mL/kg/h


def test_abls_mechanism_unknown_warns():
    p = plan(mechanism=None, formula=FluidFormula.abls)
    assert p.ml_per_kg_per_percent == 2
    assert any("Mechanism not recorded" in w for w in p.warnings)


def test_custom_formula():
    p = plan(formula=FluidFormula.custom, custom_ml_per_kg_per_percent=3.5)
    assert p.total_24h_ml == 3.5 * 70 * 40
    with pytest.raises(InvalidInput, match="custom"):
        plan(formula=FluidFormula.custom)


@pytest.mark.parametrize("weight, per_h, per_day", [(20, 60, 1_500), (8, 32, 800), (35, 75, 1_800)])
def test_child_maintenance_4_2_1_and_100_50_20(weight, per_h, per_day):
    m = maintenance_fluid(weight)
    assert m.ml_per_h == per_h
    assert m.ml_per_day == per_day


def test_urine_output_targets():
    adult = urine_output_target(70, M.flame, CONFIG, age_years=40)
    assert adult.ml_per_kg_per_h_low == 0.5 and adult.ml_per_h_low == 35
    child = urine_output_target(20, M.scald, CONFIG, age_years=6)
    assert (child.ml_per_kg_per_h_low, child.ml_per_kg_per_h_high) == (1.0, 1.5)
    assert (child.ml_per_h_low, child.ml_per_h_high) == (20, 30)


def test_below_formal_resuscitation_size_adult_and_child():
    adult = plan(tbsa_percent=15)
    assert not adult.formal_resuscitation_indicated
    assert adult.formal_resuscitation_threshold_percent == 20
    assert "Burn below 20 %TBSA: formal resuscitation is not usually required" in adult.statement
    assert adult.total_24h_ml == 4 * 70 * 15  # still computed for reference
    child = plan(weight_kg=18, age_years=4, tbsa_percent=8)
    assert not child.formal_resuscitation_indicated
    assert child.formal_resuscitation_threshold_percent == 10
    assert plan(tbsa_percent=20).formal_resuscitation_indicated
    assert plan(weight_kg=18, age_years=4, tbsa_percent=10).formal_resuscitation_indicated


@pytest.mark.parametrize(
    "overrides",
    [
        {"weight_kg": 0},
        {"weight_kg": 401},
        {"tbsa_percent": -1},
        {"tbsa_percent": 100.5},
        {"as_of": hours(-1)},  # assessment before the injury
        {"time_of_injury": hours(2), "as_of": hours(0)},  # injury in the future of as_of
        {"time_of_injury": INJURY.replace(tzinfo=None)},
        {"as_of": hours(3).replace(tzinfo=None)},
        {"fluid_given": given((-100, 1))},
        {"age_years": 140},
    ],
)
def test_impossible_input_is_rejected(overrides):
    with pytest.raises(InvalidInput):
        plan(**overrides)


def test_injury_within_clock_skew_counts_as_zero_hours():
    p = plan(time_of_injury=hours(0.05), as_of=INJURY)  # 3 min ahead, tolerance 5 min
    assert p.hours_since_injury == 0
    assert p.rate_now_ml_per_h == 700


def test_plan_is_pure_and_ignores_the_real_clock():
    # An injury in 2100, 2 h before as_of: the real clock is not consulted (the gateway refuses real-future times).
    future = dt.datetime(2100, 1, 1, tzinfo=UTC)
    p = plan(time_of_injury=future, as_of=future + dt.timedelta(hours=2))
    assert p.hours_since_injury == 2
    assert not hasattr(fluids, "utcnow")


def test_configured_clock_skew_is_used():
    # injury 8 min after as_of: within a 600 s tolerance (counts as 0 h), beyond 300 s and 0 s
    late = {"time_of_injury": INJURY + dt.timedelta(minutes=8), "as_of": INJURY}
    assert plan(**late, clock_skew_s=600).hours_since_injury == 0
    with pytest.raises(InvalidInput, match="after the assessment time"):
        plan(**late, clock_skew_s=300)
    with pytest.raises(InvalidInput, match="after the assessment time"):
        plan(time_of_injury=INJURY + dt.timedelta(seconds=1), as_of=INJURY, clock_skew_s=0)
    with pytest.raises(InvalidInput, match="clock skew"):
        plan(clock_skew_s=-1)


def test_clock_skew_has_no_default():
    args = dict(weight_kg=70, weight_source="measured, encounter", tbsa_percent=40, age_years=35, mechanism=None)
    args |= dict(time_of_injury=INJURY, as_of=INJURY, fluid_given=[], formula=FluidFormula.parkland)
    with pytest.raises(TypeError, match="clock_skew_s"):
        fluid_plan(**args, custom_ml_per_kg_per_percent=None, config=CONFIG)


# --- who is a child: each rule draws its own line ------------------------------------------


def test_light_adult_gets_adult_multiplier_no_maintenance_and_adult_urine_target():
    # 70 years, 28 kg (< 30 kg): an adult by age. ABLS 2 x 28 x 25 = 1,400 mL; Parkland 4 x 28 x 25 = 2,800 mL
    abls = plan(weight_kg=28, age_years=70, tbsa_percent=25, formula=FluidFormula.abls)
    assert abls.ml_per_kg_per_percent == 2
    assert abls.total_24h_ml == 1_400
    assert abls.multiplier_basis == "ABLS 2018: 2 mL/kg/%TBSA, adult thermal burn"
    assert abls.formal_resuscitation_threshold_percent == 20
    parkland = plan(weight_kg=28, age_years=70, tbsa_percent=25)
    assert parkland.total_24h_ml == 2_800
    for p in (abls, parkland):
        assert p.maintenance is None
        assert "Child" not in p.statement
        # adult target 0.5-1.0 mL/kg/h: 14-28 mL/h
        assert (p.urine_output_target.ml_per_h_low, p.urine_output_target.ml_per_h_high) == (14, 28)


def test_heavy_child_gets_child_multiplier_but_no_maintenance():
    # 12 years, 45 kg: a child by age (3 x 45 x 20 = 2,700 mL), but not under 30 kg: no maintenance,
    # adult urine target 0.5 x 45 = 22.5 mL/h
    p = plan(weight_kg=45, age_years=12, tbsa_percent=20, formula=FluidFormula.abls)
    assert p.ml_per_kg_per_percent == 3
    assert p.total_24h_ml == 2_700
    assert p.multiplier_basis == "ABLS 2018: 3 mL/kg/%TBSA, child (<= 14 years)"
    assert p.formal_resuscitation_threshold_percent == 10
    assert p.maintenance is None
    assert p.urine_output_target.ml_per_h_low == 22.5


@pytest.mark.parametrize("age, ml, total", [(14.0, 3, 3_000), (14.5, 3, 3_000), (14.99, 3, 3_000), (15.0, 2, 2_000)])
def test_child_by_age_runs_to_the_15th_birthday(age, ml, total):
    # "<= 14 years" is 14 completed years: 50 kg x 20 %TBSA x 3 (child) or 2 (adult)
    p = plan(weight_kg=50, age_years=age, tbsa_percent=20, formula=FluidFormula.abls)
    assert p.ml_per_kg_per_percent == ml
    assert p.total_24h_ml == total


def test_maintenance_and_urine_target_boundary_is_below_30_kg():
    # 8 years: 29.9 kg is under 30 kg -> maintenance 4x10 + 2x10 + 1x9.9 = 69.9 mL/h, child urine 29.9-44.85 mL/h
    below = plan(weight_kg=29.9, age_years=8, tbsa_percent=20)
    assert below.maintenance.ml_per_h == 69.9
    assert below.urine_output_target.ml_per_kg_per_h_low == 1.0
    assert below.urine_output_target.ml_per_h_low == 29.9
    # 30.0 kg is not: no maintenance, adult urine target 0.5 x 30 = 15 mL/h (same boundary for both)
    at = plan(weight_kg=30.0, age_years=8, tbsa_percent=20)
    assert at.maintenance is None
    assert at.urine_output_target.ml_per_kg_per_h_low == 0.5
    assert at.urine_output_target.ml_per_h_low == 15
    assert urine_output_target(30.0, M.scald, CONFIG, age_years=8).ml_per_kg_per_h_low == 0.5
    assert urine_output_target(29.9, M.scald, CONFIG, age_years=8).ml_per_kg_per_h_low == 1.0


def test_age_unknown_falls_back_to_weight_and_says_so():
    # 25 kg, age unknown: child by weight, 3 x 25 x 20 = 1,500 mL, maintenance 40 + 20 + 5 = 65 mL/h
    light = plan(weight_kg=25, age_years=None, tbsa_percent=20, formula=FluidFormula.abls)
    assert light.total_24h_ml == 1_500
    assert light.multiplier_basis == (
        "ABLS 2018: 3 mL/kg/%TBSA, child: age unknown, taken as a child from the weight (25 kg < 30 kg)"
    )
    assert light.maintenance.ml_per_h == 65
    assert light.formal_resuscitation_threshold_percent == 10
    assert any(w.startswith("Age not recorded") for w in light.warnings)
    # 70 kg, age unknown: adult, 2 x 70 x 20 = 2,800 mL
    heavy = plan(weight_kg=70, age_years=None, tbsa_percent=20, formula=FluidFormula.abls)
    assert heavy.total_24h_ml == 2_800
    assert heavy.multiplier_basis.endswith("(adult: age unknown, taken as an adult from the weight (70 kg >= 30 kg))")
    assert heavy.maintenance is None


def test_urine_target_needs_the_age():
    with pytest.raises(TypeError, match="age_years"):
        urine_output_target(20, M.scald, CONFIG)


def test_weight_source_is_reported():
    assert plan(weight_source="estimated, patient record").weight_source == "estimated, patient record"
    with pytest.raises(InvalidInput, match="weight source"):
        plan(weight_source="")


# --- validate_resuscitation: what the gateway refuses at write time -------------------------


def test_valid_resuscitation_passes():
    assert validate_resuscitation(Resuscitation(encounter_id=EID, fluid_given=given((500, 1)))) is None
    custom = Resuscitation(encounter_id=EID, formula=FluidFormula.custom, custom_ml_per_kg_per_percent=3)
    assert validate_resuscitation(custom) is None


def test_custom_formula_without_value_names_the_field():
    with pytest.raises(InvalidInput, match=r"custom.*\(\$\.custom_ml_per_kg_per_percent\)") as exc:
        validate_resuscitation(Resuscitation(encounter_id=EID, formula=FluidFormula.custom))
    assert [p.field for p in exc.value.errors] == ["$.custom_ml_per_kg_per_percent"]


def test_negative_volumes_are_refused_each_by_path():
    r = Resuscitation(encounter_id=EID, fluid_given=given((500, 1), (-100, 2), (-5, 3)))
    with pytest.raises(InvalidInput, match="fluid volume -100 mL is impossible") as exc:
        validate_resuscitation(r)
    assert [p.field for p in exc.value.errors] == ["$.fluid_given[1].volume_ml", "$.fluid_given[2].volume_ml"]


def test_custom_value_out_of_range_is_refused():
    r = Resuscitation(encounter_id=EID, formula=FluidFormula.custom, custom_ml_per_kg_per_percent=9)
    with pytest.raises(InvalidInput, match="custom formula 9 mL/kg/%TBSA is impossible") as exc:
        validate_resuscitation(r)
    assert exc.value.errors[0].field == "$.custom_ml_per_kg_per_percent"
