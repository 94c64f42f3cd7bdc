"""Burn fluid plans (Parkland / ABLS 2018), child maintenance and urine targets: worked examples."""

from __future__ import annotations

import datetime as dt

import pytest

from processing.clinical import fluids
from processing.clinical.fluids import fluid_plan, maintenance_fluid, urine_output_target
from schemas.clinical_results import FluidPhase
from schemas.config import ClinicalConfig
from schemas.errors import InvalidInput
from schemas.record_parts import FluidFormula, FluidGiven
from schemas.record_parts import MechanismType as M

UTC = dt.UTC
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


def test_abls_child_by_weight_alone():
    # 16 years old but 25 kg (< 30 kg): child rule, 3 x 25 x 20 = 1,500 mL
    p = plan(weight_kg=25, tbsa_percent=20, age_years=16, formula=FluidFormula.abls)
    assert p.total_24h_ml == 1_500
    assert p.maintenance is not None


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
    adult = urine_output_target(70, M.flame, CONFIG)
    assert adult.ml_per_kg_per_h_low == 0.5 and adult.ml_per_h_low == 35
    child = urine_output_target(20, M.scald, CONFIG)
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


def test_injury_in_the_real_future_is_rejected(monkeypatch):
    monkeypatch.setattr(fluids, "utcnow", lambda: INJURY - dt.timedelta(hours=1))
    with pytest.raises(InvalidInput, match="future"):
        plan(as_of=hours(1))
