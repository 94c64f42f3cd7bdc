"""Lund-Browder %TBSA, Rule of Nines, palm estimate and Mosteller BSA against published values.

Expected figures are worked by hand from the published whole-region Lund-Browder values,
never taken from the code's own output.
"""

from __future__ import annotations

import datetime as dt

import pytest

from processing.clinical.bsa import mosteller
from processing.clinical.lund_browder import (
    NinesVariant,
    column_description,
    compute_tbsa,
    palm_estimate,
    region_percent,
    rule_of_nines,
    validate_chart,
)
from schemas.burn_chart import AgeAdjustment, BurnChart, BurnChartEntry, BurnDepth
from schemas.burn_chart import LundBrowderRegion as R
from schemas.errors import InvalidInput

EID = "0192f3b4-6a8e-7c3d-9b1a-2f4e5d6c7b8a"
AT = dt.datetime(2024, 3, 1, 10, 0, tzinfo=dt.UTC)
BAND, INTERP = AgeAdjustment.band, AgeAdjustment.interpolate
D = BurnDepth

# Published whole-region values, columns 0, 1, 5, 10, 15 years, adult ("each" for paired parts).
PUBLISHED = {
    "head": (19, 17, 13, 11, 9, 7),
    "thigh": (5.5, 6.5, 8, 8.5, 9, 9.5),
    "lower_leg": (5, 5, 5.5, 6, 6.5, 7),
}
COLUMN_AGES = (0, 1, 5, 10, 15, 18)


def chart(*entries, method=BAND) -> BurnChart:
    return BurnChart(
        encounter_id=EID,
        assessed_at=AT,
        entries=[BurnChartEntry(region=r, fraction=f, depth=d) for r, f, d in entries],
        age_adjustment=method,
    )


def tbsa(c: BurnChart, age: float):
    return compute_tbsa(c, age, age_source="date_of_birth")


def whole(*regions, depth=D.deep_partial, fraction=1.0) -> list[tuple]:
    return [(r, fraction, depth) for r in regions]


RIGHT_ARM = [r for r in R if r.value.startswith(("upper_arm_right", "lower_arm_right", "hand_right"))]
HEAD = [R.head_anterior, R.head_posterior]
NECK = [R.neck_anterior, R.neck_posterior]
THIGHS = [r for r in R if r.value.startswith("thigh_")]


@pytest.mark.parametrize("age", [0, 1, 5, 10, 15, 18, 0.5, 3, 7, 12, 16, 40, 130])
def test_every_band_column_sums_to_exactly_100(age):
    assert sum(region_percent(r, age, BAND) for r in R) == 100.0


@pytest.mark.parametrize("age", [0.5, 3, 7.5, 12, 16.5])
def test_interpolated_ages_sum_to_100(age):
    assert sum(region_percent(r, age, INTERP) for r in R) == pytest.approx(100.0, abs=1e-9)


@pytest.mark.parametrize("col, age", list(enumerate(COLUMN_AGES)))
def test_split_halves_add_up_to_published_whole_regions(col, age):
    assert (
        region_percent(R.head_anterior, age, BAND) + region_percent(R.head_posterior, age, BAND)
        == (PUBLISHED["head"][col])
    )
    thigh = region_percent(R.thigh_left_anterior, age, BAND) + region_percent(R.thigh_left_posterior, age, BAND)
    assert thigh == PUBLISHED["thigh"][col]
    leg = region_percent(R.lower_leg_right_anterior, age, BAND) + region_percent(R.lower_leg_right_posterior, age, BAND)
    assert leg == PUBLISHED["lower_leg"][col]
    assert region_percent(R.buttock_left, age, BAND) == 2.5
    assert region_percent(R.genitalia, age, BAND) == 1
    assert region_percent(R.hand_right_palmar, age, BAND) == 1.25


def test_adult_anterior_trunk_deep_and_whole_right_arm_superficial_partial():
    # 13 (anterior trunk) + 4 + 3 + 2.5 (upper arm, lower arm, hand) = 22.5
    result = tbsa(chart(*whole(R.trunk_anterior), *whole(*RIGHT_ARM, depth=D.superficial_partial)), 35)
    assert result.tbsa_percent == 22.5
    assert result.deep_partial_percent == 13
    assert result.superficial_partial_percent == 9.5
    assert result.partial_thickness_percent == 22.5
    assert result.full_thickness_percent == 0
    assert len(result.contributions) == 7
    assert result.age_adjustment == "band: column 'adult' (age >= 18)"
    # Nines: anterior trunk 18 + right arm 9
    assert result.rule_of_nines_percent == 27


def test_superficial_only_burns_count_zero_but_are_reported():
    # adult anterior trunk 13 + head 7, all epidermal
    result = tbsa(chart(*whole(R.trunk_anterior, *HEAD, depth=D.superficial)), 50)
    assert result.tbsa_percent == 0
    assert result.excluded_superficial_percent == 20
    assert result.rule_of_nines_percent == 0


def test_one_year_old_whole_head_is_17_percent():
    assert tbsa(chart(*whole(*HEAD)), 1).tbsa_percent == 17


def test_five_year_old_both_thighs_is_16_percent():
    result = tbsa(chart(*whole(*THIGHS, depth=D.full_thickness)), 5)
    assert result.tbsa_percent == 16
    assert result.full_thickness_percent == 16
    assert result.age_adjustment == "band: column '5 years' (5 <= age < 10)"


def test_depths_and_fractions_within_one_region():
    # adult posterior trunk 13: 0.5 superficial partial, 0.2 full thickness, 0.3 superficial
    result = tbsa(
        chart(
            (R.trunk_posterior, 0.5, D.superficial_partial),
            (R.trunk_posterior, 0.2, D.full_thickness),
            (R.trunk_posterior, 0.3, D.superficial),
        ),
        30,
    )
    assert result.superficial_partial_percent == 6.5
    assert result.full_thickness_percent == 2.6
    assert result.excluded_superficial_percent == 3.9
    assert result.tbsa_percent == 9.1


@pytest.mark.parametrize(
    "age, head",
    [(0.99, 19), (1, 17), (4.99, 17), (5, 13), (9.99, 13), (10, 11), (14.9, 11), (15, 9), (17.99, 9), (18, 7), (90, 7)],
)
def test_band_edges(age, head):
    assert tbsa(chart(*whole(*HEAD)), age).tbsa_percent == head


def test_interpolated_head_at_seven_and_a_half_is_12():
    result = tbsa(chart(*whole(*HEAD), method=INTERP), 7.5)
    assert result.tbsa_percent == 12  # halfway between 13 (5 y) and 11 (10 y)
    assert result.age_adjustment == "interpolated between columns '5 years' and '10 years' (age 7.5)"


def test_interpolation_to_adult_column_and_beyond():
    # 16.5 y: halfway between 15 y (9) and adult taken as 18 y (7) -> 8; beyond 18 constant 7
    assert tbsa(chart(*whole(*HEAD), method=INTERP), 16.5).tbsa_percent == 8
    assert tbsa(chart(*whole(*HEAD), method=INTERP), 60).tbsa_percent == 7
    assert "taken as 18 years" in column_description(16.5, INTERP)


def test_rule_of_nines_from_chart_adult_anterior_trunk_is_18():
    result = tbsa(chart(*whole(R.trunk_anterior)), 40)
    assert result.tbsa_percent == 13
    assert result.rule_of_nines_percent == 18
    assert result.rule_of_nines_variant.startswith("adult")


def test_rule_of_nines_from_chart_child_head_and_neck_is_18():
    # 3-year-old: Lund-Browder head 17 + neck 2 = 19 %; child nines head & neck = 18
    result = tbsa(chart(*whole(*HEAD, *NECK)), 3)
    assert result.tbsa_percent == 19
    assert result.rule_of_nines_percent == 18
    assert result.rule_of_nines_variant.startswith("child")


def test_rule_of_nines_half_group_and_buttocks_in_posterior_trunk():
    # adult: buttocks 2.5 + 2.5 of a posterior-trunk group of 13 + 5 = 18 -> 5/18 of 18 = 5
    assert tbsa(chart(*whole(R.buttock_left, R.buttock_right)), 40).rule_of_nines_percent == 5
    # adult anterior trunk half burned -> 9
    assert tbsa(chart((R.trunk_anterior, 0.5, D.deep_partial)), 40).rule_of_nines_percent == 9


def test_standalone_rule_of_nines():
    assert rule_of_nines({"head_neck": 1, "arm_right": 0.5}, NinesVariant.adult) == 13.5
    assert rule_of_nines({"leg_left": 1, "head_neck": 1}, "child") == 32
    with pytest.raises(InvalidInput, match="perineum"):
        rule_of_nines({"perineum": 1}, "child")
    with pytest.raises(InvalidInput):
        rule_of_nines({"tail": 1}, "adult")
    with pytest.raises(InvalidInput):
        rule_of_nines({"head_neck": 1.5}, "adult")


def test_palm_estimate():
    assert palm_estimate(3) == 2.4
    assert palm_estimate(0) == 0
    with pytest.raises(InvalidInput):
        palm_estimate(-1)


@pytest.mark.parametrize("age", [-1, 131, float("nan")])
def test_impossible_age_is_rejected(age):
    with pytest.raises(InvalidInput, match="age"):
        tbsa(chart(*whole(*HEAD)), age)


def test_region_fractions_over_one_are_rejected_naming_the_region():
    c = chart((R.thigh_left_anterior, 0.7, D.deep_partial), (R.thigh_left_anterior, 0.5, D.full_thickness))
    with pytest.raises(InvalidInput, match="Left thigh, front"):
        tbsa(c, 30)


def test_same_region_and_depth_twice_is_rejected():
    c = chart((R.genitalia, 0.2, D.deep_partial), (R.genitalia, 0.3, D.deep_partial))
    with pytest.raises(InvalidInput, match="Genitalia"):
        tbsa(c, 30)


def test_fraction_out_of_range_is_rejected():
    with pytest.raises(InvalidInput):
        tbsa(chart((R.genitalia, 1.2, D.deep_partial)), 30)


def test_mosteller_published_examples():
    assert mosteller(80, 180).bsa_m2 == 2.0  # sqrt(180 x 80 / 3600) = sqrt(4)
    assert mosteller(16, 100).bsa_m2 == 0.667  # sqrt(1600 / 3600) = 2/3


@pytest.mark.parametrize("weight, height", [(0, 170), (-5, 170), (401, 170), (70, 19), (70, 273), (float("nan"), 170)])
def test_mosteller_rejects_impossible_body_size(weight, height):
    with pytest.raises(InvalidInput):
        mosteller(weight, height)


def test_result_says_where_the_age_came_from():
    assert tbsa(chart(*whole(*HEAD)), 40).age_source == "date_of_birth"
    assert compute_tbsa(chart(*whole(*HEAD)), 40, age_source="estimate").age_source == "estimate"
    with pytest.raises(InvalidInput, match="age source"):
        compute_tbsa(chart(*whole(*HEAD)), 40, age_source="guess")


def test_validate_chart_accepts_a_possible_chart():
    assert (
        validate_chart(
            chart((R.trunk_posterior, 0.5, D.superficial_partial), (R.trunk_posterior, 0.5, D.full_thickness))
        )
        is None
    )


def test_validate_chart_names_every_entry_of_an_overfull_region():
    c = chart(
        (R.genitalia, 0.1, D.deep_partial),
        (R.thigh_left_anterior, 0.7, D.deep_partial),
        (R.thigh_left_anterior, 0.5, D.full_thickness),
    )
    with pytest.raises(
        InvalidInput,
        match=r"Left thigh, front is charted as 1\.20 .*\(\$\.entries\[1\]\.fraction, \$\.entries\[2\]\.fraction\)",
    ) as exc:
        validate_chart(c)
    assert [p.field for p in exc.value.errors] == ["$.entries[1].fraction", "$.entries[2].fraction"]


def test_validate_chart_names_the_duplicate_entry():
    c = chart(
        (R.genitalia, 0.2, D.deep_partial), (R.head_anterior, 1, D.superficial), (R.genitalia, 0.3, D.deep_partial)
    )
    with pytest.raises(
        InvalidInput, match=r"Genitalia is charted twice at depth deep_partial \(also \$\.entries\[0\]\)"
    ) as exc:
        validate_chart(c)
    assert [p.field for p in exc.value.errors] == ["$.entries[2].depth"]


def test_validate_chart_names_an_impossible_fraction():
    with pytest.raises(InvalidInput, match="burned fraction of genitalia 1.2 is impossible") as exc:
        validate_chart(chart((R.head_anterior, 1, D.superficial), (R.genitalia, 1.2, D.deep_partial)))
    assert [p.field for p in exc.value.errors] == ["$.entries[1].fraction"]


def test_compute_tbsa_uses_validate_chart(monkeypatch):
    from processing.clinical import lund_browder

    seen = []
    monkeypatch.setattr(lund_browder, "validate_chart", seen.append)
    tbsa(chart(*whole(*HEAD)), 40)
    assert len(seen) == 1
