"""The shared input checks and the child predicates, one rule at a time."""

from __future__ import annotations

import datetime as dt
import math

import pytest

from processing.clinical.checks import aware, check_age, check_height, check_weight, finite, member
from processing.clinical.children import aba_pediatric, child_by_age, fluid_child, small_child
from schemas.base import AGE_MAX_YEARS, HEIGHT_MAX_CM, HEIGHT_MIN_CM, WEIGHT_MAX_KG
from schemas.burn_chart import BurnDepth
from schemas.config import ClinicalConfig
from schemas.errors import InvalidInput

CONFIG = ClinicalConfig()


@pytest.mark.parametrize("value", [True, False, "3", None, math.nan, math.inf, -math.inf])
def test_finite_refuses_what_is_not_a_real_number(value):
    with pytest.raises(InvalidInput, match="is not a number"):
        finite(value, "dose", 0, 10)


def test_finite_range_and_open_lower_bound():
    assert finite(0, "dose", 0, 10) == 0.0 and isinstance(finite(3, "dose", 0, 10), float)
    assert finite(10, "dose", 0, 10) == 10
    with pytest.raises(InvalidInput, match="dose 0 mg is impossible: enter a number above 0, up to 10 mg"):
        finite(0, "dose", 0, 10, lo_open=True, unit="mg")
    with pytest.raises(InvalidInput, match="enter a number 0 mL or more"):
        finite(-1, "volume", 0, unit="mL")
    assert finite(1e6, "volume", 0) == 1e6


def test_finite_with_a_field_names_it_and_carries_a_field_problem():
    with pytest.raises(InvalidInput, match=r"\(\$\.entries\[2\]\.fraction\)$") as exc:
        finite(1.5, "fraction", 0, 1, field="$.entries[2].fraction")
    [problem] = exc.value.errors
    assert problem.field == "$.entries[2].fraction"
    assert problem.message == "fraction 1.5 is impossible: enter a number from 0 to 1"


def test_body_limits_come_from_the_schema_constants():
    assert (AGE_MAX_YEARS, WEIGHT_MAX_KG, HEIGHT_MIN_CM, HEIGHT_MAX_CM) == (130, 400, 20, 272)
    assert check_age(130) == 130 and check_weight(400) == 400
    assert check_height(20) == 20 and check_height(272) == 272
    for check, bad in ((check_age, 130.5), (check_weight, 400.5), (check_weight, 0), (check_height, 19.9)):
        with pytest.raises(InvalidInput, match="impossible"):
            check(bad)


def test_aware_and_member():
    at = dt.datetime(2024, 3, 1, 8, tzinfo=dt.UTC)
    assert aware(at, "time") is at
    with pytest.raises(InvalidInput, match="has no UTC offset"):
        aware(at.replace(tzinfo=None), "time")
    with pytest.raises(InvalidInput, match="is not a date and time"):
        aware("2024-03-01", "time")
    assert member(BurnDepth, "deep_partial", "depth") is BurnDepth.deep_partial
    with pytest.raises(InvalidInput, match="unknown depth 'charred': use one of 'superficial'"):
        member(BurnDepth, "charred", "depth")


@pytest.mark.parametrize("age, child", [(0, True), (14, True), (14.5, True), (14.999, True), (15, False), (70, False)])
def test_child_by_age_is_up_to_the_15th_birthday(age, child):
    assert child_by_age(age, CONFIG) is child


def test_fluid_child_goes_by_age_then_weight():
    assert fluid_child(12, 45, CONFIG)[0] is True
    assert fluid_child(70, 28, CONFIG)[0] is False
    assert fluid_child(None, 29.9, CONFIG) == (
        True,
        "child: age unknown, taken as a child from the weight (29.9 kg < 30 kg)",
    )
    assert fluid_child(None, 30, CONFIG)[0] is False


@pytest.mark.parametrize(
    "age, weight, small",
    [(8, 29.9, True), (8, 30.0, False), (12, 45, False), (70, 28, False), (16, 25, False), (None, 25, True)],
)
def test_small_child_for_maintenance_and_urine(age, weight, small):
    assert small_child(age, weight, CONFIG) is small


@pytest.mark.parametrize(
    "age, weight, pediatric",
    [(14.5, 50, True), (15, 50, False), (16, 28, True), (None, 29.9, True), (None, 30, None), (None, None, None)],
)
def test_aba_pediatric_keeps_the_aba_wording(age, weight, pediatric):
    assert aba_pediatric(age, weight, CONFIG) is pediatric
