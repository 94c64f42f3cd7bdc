"""Burn-center referral by size, depth, area and age: ABA 2022 two tiers and the older single list."""

from __future__ import annotations

import pytest

from processing.clinical import referral, referral_aba2022
from processing.clinical.referral import assess_referral
from schemas.burn_chart import BurnDepth as D
from schemas.burn_chart import LundBrowderRegion as R
from schemas.burn_chart import SpecialArea
from schemas.clinical_results import ReferralTier
from schemas.record_parts import MechanismType as M
from tests.referral_cases import CONSULT, IMMEDIATE, criterion, inputs


def test_adult_15_percent_partial_trunk_flame():
    # adult: anterior trunk 13 + right buttock 0.8 x 2.5 = 2 -> 15 %TBSA superficial partial
    r = assess_referral(
        inputs((R.trunk_anterior, 1.0, D.superficial_partial), (R.buttock_right, 0.8, D.superficial_partial))
    )
    assert r.current.met == ["aba2022.partial_ge_10"]
    assert r.current.recommendation == IMMEDIATE
    assert criterion(r.current, "aba2022.partial_ge_10").tier is ReferralTier.immediate
    assert criterion(r.current, "aba2022.partial_ge_10").reason == "partial-thickness burns 15.00 %TBSA (>= 10)"
    assert r.current.undetermined == []
    assert r.older.met == ["aba2006.partial_gt_10"]
    assert r.older.recommendation == "Refer to a burn center"
    assert all(c.tier is ReferralTier.refer for c in r.older.criteria)


def test_adult_5_percent_partial_forearm_only_needs_consultation():
    # right lower arm 3 + left upper arm anterior 2 = 5 %TBSA
    r = assess_referral(
        inputs(
            (R.lower_arm_right_anterior, 1.0, D.superficial_partial),
            (R.lower_arm_right_posterior, 1.0, D.superficial_partial),
            (R.upper_arm_left_anterior, 1.0, D.superficial_partial),
        )
    )
    assert r.current.met == ["aba2022.partial_lt_10"]
    assert r.current.recommendation == CONSULT
    assert criterion(r.current, "aba2022.partial_lt_10").tier is ReferralTier.consult
    assert r.older.met == []
    assert r.older.undetermined == []
    assert r.older.recommendation == "No criterion met on the recorded data"


def test_exactly_10_percent_partial_is_immediate_now_but_not_over_10_before():
    # adult: both lower legs anterior (3.5 + 3.5) + right lower arm (1.5 + 1.5) = 10
    entries = [
        (r, 1.0, D.deep_partial)
        for r in (
            R.lower_leg_left_anterior,
            R.lower_leg_right_anterior,
            R.lower_arm_right_anterior,
            R.lower_arm_right_posterior,
        )
    ]
    r = assess_referral(inputs(*entries))
    assert "aba2022.partial_ge_10" in r.current.met
    assert "aba2022.partial_lt_10" not in r.current.met
    assert "aba2006.partial_gt_10" not in r.older.met


def test_small_full_thickness_burn_is_immediate():
    # adult right lower-leg front 3.5 x 4/7 = 2 %TBSA full thickness
    r = assess_referral(inputs((R.lower_leg_right_anterior, 4 / 7, D.full_thickness)))
    assert "aba2022.full_thickness" in r.current.met
    assert r.current.recommendation == IMMEDIATE
    assert criterion(r.current, "aba2022.full_thickness").reason == (
        "full-thickness burns 2.00 %TBSA (right lower leg, front)"
    )
    assert "aba2006.third_degree" in r.older.met


def test_child_3_years_4_percent_scald_is_immediate():
    # 1-year column: anterior trunk 13 x 4/13 = 4 %TBSA; ABA 2022 puts all pediatric burns in the immediate tier
    r = assess_referral(inputs((R.trunk_anterior, 4 / 13, D.superficial_partial), age=3, weight=14, mechanism=M.scald))
    assert set(r.current.met) == {"aba2022.pediatric", "aba2022.partial_lt_10"}
    assert r.current.recommendation == IMMEDIATE
    pediatric = criterion(r.current, "aba2022.pediatric")
    assert pediatric.tier is ReferralTier.immediate
    assert pediatric.reason == "child (age 3 years, weight 14 kg) with burns charted (trunk, front)"
    facility = criterion(r.older, "aba2006.children_facility")
    assert facility.met is None
    assert "facility" in facility.reason
    assert r.older.met == []
    assert r.older.undetermined == ["aba2006.children_facility"]
    assert r.older.recommendation.startswith("No criterion met on the recorded data")


def test_children_facility_does_not_apply_to_adults():
    r = assess_referral(inputs((R.trunk_anterior, 0.1, D.superficial_partial)))
    assert criterion(r.older, "aba2006.children_facility").met is False


def test_child_by_weight_is_pediatric():
    r = assess_referral(inputs((R.trunk_anterior, 0.1, D.superficial_partial), age=16, weight=28))
    assert "aba2022.pediatric" in r.current.met
    assert r.current.recommendation == IMMEDIATE


def test_child_superficial_burn_is_still_a_pediatric_burn():
    r = assess_referral(inputs((R.lower_arm_left_anterior, 0.5, D.superficial), age=8, weight=25))
    assert r.current.met == ["aba2022.pediatric"]
    assert r.current.recommendation == IMMEDIATE


def test_pediatric_undetermined_without_age_or_weight():
    r = assess_referral(inputs((R.trunk_anterior, 0.1, D.superficial_partial), age=None, weight=None))
    pediatric = criterion(r.current, "aba2022.pediatric")
    assert pediatric.met is None
    assert "age or weight is needed" in pediatric.reason


def test_hand_deep_partial_is_immediate_superficial_partial_only_older_list():
    deep = assess_referral(inputs((R.hand_right_dorsal, 1.0, D.deep_partial)))
    assert "aba2022.critical_areas_deep" in deep.current.met
    assert deep.current.recommendation == IMMEDIATE
    assert "aba2006.critical_areas" in deep.older.met
    shallow = assess_referral(inputs((R.hand_right_dorsal, 1.0, D.superficial_partial)))
    assert "aba2022.critical_areas_deep" not in shallow.current.met
    assert "aba2006.critical_areas" in shallow.older.met


def test_face_from_anterior_head_and_perineum_from_special_areas():
    face = assess_referral(inputs((R.head_anterior, 0.5, D.full_thickness)))
    reason = criterion(face.current, "aba2022.critical_areas_deep").reason
    assert reason.startswith("face: head, front (full thickness)")
    assert "anterior head region is taken to include the face" in reason
    perineum = assess_referral(
        inputs((R.genitalia, 0.0, D.superficial_partial), special=[(SpecialArea.perineum, D.deep_partial)])
    )
    assert "aba2022.critical_areas_deep" in perineum.current.met
    assert "perineum" in criterion(perineum.current, "aba2022.critical_areas_deep").reason


def test_facial_flash_burn_in_enclosed_flame_is_consult_not_immediate():
    # superficial flash burn of the face in a house fire, no stronger airway sign
    r = assess_referral(inputs((R.head_anterior, 0.3, D.superficial), enclosed=True, mechanism=M.flame))
    assert r.current.met == ["aba2022.inhalation_potential"]
    assert criterion(r.current, "aba2022.inhalation_potential").reason == (
        "facial burns (a possible flash burn); smoke exposure (flame burn in an enclosed space)"
    )
    assert r.current.recommendation == CONSULT
    # the older list still reads this as inhalation injury
    assert "aba2006.inhalation" in r.older.met


def test_no_chart_leaves_size_criteria_undetermined():
    r = assess_referral(inputs(with_chart=False))
    for code in (
        "aba2022.full_thickness",
        "aba2022.partial_ge_10",
        "aba2022.critical_areas_deep",
        "aba2022.partial_lt_10",
        "aba2022.potentially_deep",
    ):
        assert criterion(r.current, code).met is None
        assert criterion(r.current, code).reason == "no burn chart recorded"
        assert code in r.current.undetermined
    assert "aba2006.partial_gt_10" in r.older.undetermined
    assert r.current.recommendation.startswith("No ABA referral criterion met on the recorded data")
    assert "Thermal: full-thickness burns" in r.current.recommendation and "aba2022." not in r.current.recommendation


def test_chart_without_age_decides_depth_but_not_size():
    r = assess_referral(
        inputs((R.thigh_left_anterior, 0.5, D.full_thickness), (R.trunk_anterior, 0.5, D.deep_partial), age=None)
    )
    assert "aba2022.full_thickness" in r.current.met
    assert criterion(r.current, "aba2022.partial_ge_10").met is None
    assert "age" in criterion(r.current, "aba2022.partial_ge_10").reason


def test_deep_partial_3_percent_forearm_adult_is_potentially_deep():
    # adult right lower arm 1.5 + 1.5 = 3 %TBSA deep partial: not a critical area
    r = assess_referral(
        inputs((R.lower_arm_right_anterior, 1.0, D.deep_partial), (R.lower_arm_right_posterior, 1.0, D.deep_partial))
    )
    assert set(r.current.met) == {"aba2022.partial_lt_10", "aba2022.potentially_deep"}
    deep = criterion(r.current, "aba2022.potentially_deep")
    assert deep.tier is ReferralTier.consult
    assert deep.reason == (
        "deep partial-thickness burns 3.00 %TBSA (right forearm, front; right forearm, back): potentially deep"
    )
    assert r.current.recommendation == CONSULT


def test_full_thickness_alone_is_not_counted_as_potentially_deep():
    r = assess_referral(inputs((R.thigh_left_anterior, 0.2, D.full_thickness)))
    assert criterion(r.current, "aba2022.potentially_deep").met is False
    assert r.current.recommendation == IMMEDIATE


def test_deep_partial_special_area_is_potentially_deep():
    r = assess_referral(
        inputs((R.trunk_anterior, 0.0, D.superficial), special=[(SpecialArea.major_joint, D.deep_partial)])
    )
    assert "aba2022.potentially_deep" in r.current.met
    assert "aba2022.critical_areas_deep" in r.current.met


def test_consultation_names_open_immediate_criteria():
    r = assess_referral(inputs((R.lower_arm_left_anterior, 0.5, D.superficial_partial), pain=None))
    assert r.current.met == ["aba2022.partial_lt_10"]
    assert r.current.recommendation == f"{CONSULT}; not assessable from the record: Thermal: poorly controlled pain"
    assert r.current.undetermined == ["aba2022.pain"]  # the codes are for machines, the recommendation for people


def test_current_table_matches_the_published_two_tiers():
    immediate, consult = ReferralTier.immediate, ReferralTier.consult
    r = assess_referral(inputs((R.trunk_anterior, 0.1, D.superficial)))
    assert r.current.version == "ABA 2022 (two-tier)"
    assert [(c.code, c.tier) for c in r.current.criteria] == [
        ("aba2022.full_thickness", immediate),
        ("aba2022.partial_ge_10", immediate),
        ("aba2022.critical_areas_deep", immediate),
        ("aba2022.comorbidities", immediate),
        ("aba2022.trauma", immediate),
        ("aba2022.pain", immediate),
        ("aba2022.inhalation", immediate),
        ("aba2022.pediatric", immediate),
        ("aba2022.chemical", immediate),
        ("aba2022.high_voltage", immediate),
        ("aba2022.partial_lt_10", consult),
        ("aba2022.potentially_deep", consult),
        ("aba2022.inhalation_potential", consult),
        ("aba2022.low_voltage", consult),
    ]
    assert len(r.older.criteria) == 10
    for module in (referral, referral_aba2022):
        doc = " ".join(module.__doc__.split())
        assert "American Burn Association, Guidelines for Burn Patient Referral, 2022" in doc
        assert "checked against the current published version by the clinical lead" in doc


def test_superficial_only_adult_burn_meets_nothing():
    r = assess_referral(inputs((R.trunk_anterior, 0.5, D.superficial)))
    assert r.current.met == [] and r.older.met == []
    assert r.current.recommendation == "No ABA referral criterion met on the recorded data"
    assert r.notice


@pytest.mark.parametrize("age, met", [(14.5, True), (15.0, False)])
def test_pediatric_by_age_runs_to_the_15th_birthday(age, met):
    # ABA "<= 14 years": a 50 kg 14.5-year-old is a child, a 50 kg 15-year-old is not
    r = assess_referral(inputs((R.trunk_anterior, 0.1, D.superficial_partial), age=age, weight=50))
    assert ("aba2022.pediatric" in r.current.met) is met
