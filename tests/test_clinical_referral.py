"""Burn-center referral: ABA 2022 two-tier criteria and the older single list, case by case."""

from __future__ import annotations

import datetime as dt

import pytest

from processing.clinical import referral, referral_aba2022
from processing.clinical.lund_browder import compute_tbsa
from processing.clinical.referral import ReferralInputs, assess_referral
from schemas.burn_chart import BurnChart, BurnChartEntry, SpecialArea, SpecialAreaInvolvement
from schemas.burn_chart import BurnDepth as D
from schemas.burn_chart import LundBrowderRegion as R
from schemas.clinical_results import ReferralTier
from schemas.record_parts import (
    Airway,
    AirwayIntervention,
    Breathing,
    Intake,
    Mechanism,
    OtherInjury,
    PrimarySurvey,
    SecondarySurvey,
    SocialContext,
)
from schemas.record_parts import (
    MechanismType as M,
)

EID = "0192f3b4-6a8e-7c3d-9b1a-2f4e5d6c7b8a"
AT = dt.datetime(2024, 3, 1, 10, 0, tzinfo=dt.UTC)
IMMEDIATE = "Immediate consultation with consideration for transfer"
CONSULT = "Consultation recommended"


def chart(*entries, special=()) -> BurnChart:
    return BurnChart(
        encounter_id=EID,
        assessed_at=AT,
        entries=[BurnChartEntry(region=r, fraction=f, depth=d) for r, f, d in entries],
        special_areas=[SpecialAreaInvolvement(area=a, depth=d) for a, d in special],
    )


def inputs(
    *entries,
    age=35.0,
    weight=70.0,
    special=(),
    mechanism=M.flame,
    enclosed=False,
    voltage=None,
    airway=None,
    breathing=None,
    injuries=(),
    burn_greatest=None,
    comorbidities=(),
    social=None,
    pain=False,
    with_chart=True,
    with_primary=True,
) -> ReferralInputs:
    """A complete record with nothing flagged unless asked: every criterion can be decided."""
    c = chart(*entries, special=special) if with_chart else None
    primary = PrimarySurvey(
        encounter_id=EID,
        assessed_at=AT,
        airway=airway or Airway(),
        breathing=breathing or Breathing(),
        pain_poorly_controlled=pain,
    )
    return ReferralInputs(
        age_years=age,
        weight_kg=weight,
        tbsa=compute_tbsa(c, age, age_source="estimate") if c is not None and age is not None else None,
        chart=c,
        mechanism=Mechanism(encounter_id=EID, type=mechanism, enclosed_space=enclosed, voltage_v=voltage),
        primary=primary if with_primary else None,
        secondary=SecondarySurvey(
            encounter_id=EID,
            assessed_at=AT,
            other_injuries=[OtherInjury(description=d, major=True) for d in injuries],
            burn_poses_greatest_risk=burn_greatest,
        ),
        intake=Intake(
            encounter_id=EID, significant_comorbidities=list(comorbidities), social=social or SocialContext()
        ),
    )


def criterion(result, code):
    return next(c for c in result.criteria if c.code == code)


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
        "full-thickness burns 2.00 %TBSA (lower_leg_right_anterior)"
    )
    assert "aba2006.third_degree" in r.older.met


def test_chemical_is_immediate_in_both():
    r = assess_referral(inputs((R.lower_arm_left_anterior, 0.5, D.superficial_partial), mechanism=M.chemical))
    assert "aba2022.chemical" in r.current.met
    assert r.current.recommendation == IMMEDIATE
    assert "aba2006.chemical" in r.older.met


def test_child_3_years_4_percent_scald_is_immediate():
    # 1-year column: anterior trunk 13 x 4/13 = 4 %TBSA; ABA 2022 puts all pediatric burns in the immediate tier
    r = assess_referral(inputs((R.trunk_anterior, 4 / 13, D.superficial_partial), age=3, weight=14, mechanism=M.scald))
    assert set(r.current.met) == {"aba2022.pediatric", "aba2022.partial_lt_10"}
    assert r.current.recommendation == IMMEDIATE
    pediatric = criterion(r.current, "aba2022.pediatric")
    assert pediatric.tier is ReferralTier.immediate
    assert pediatric.reason == "child (age 3 years, weight 14 kg) with burns charted (trunk_anterior)"
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
    assert "face" in reason and "anterior head region is taken to include the face" in reason
    perineum = assess_referral(
        inputs((R.genitalia, 0.0, D.superficial_partial), special=[(SpecialArea.perineum, D.deep_partial)])
    )
    assert "aba2022.critical_areas_deep" in perineum.current.met
    assert "perineum" in criterion(perineum.current, "aba2022.critical_areas_deep").reason


@pytest.mark.parametrize(
    "airway, breathing, enclosed, face",
    [
        (Airway(singed_nasal_hair=True, carbonaceous_sputum=True), None, False, False),
        (Airway(stridor=True), None, False, False),
        (Airway(carbonaceous_sputum=True), None, False, False),
        (Airway(soot_in_mouth_or_nose=True), None, False, False),
        (Airway(hoarse_voice=True), None, False, False),
        (Airway(oropharyngeal_oedema=True), None, False, False),
        (Airway(intervention=AirwayIntervention.intubated), None, False, False),
        (Airway(intervention=AirwayIntervention.surgical_airway), None, False, False),
        (None, Breathing(carboxyhaemoglobin_percent=12), False, False),
        (Airway(carbonaceous_sputum=True, facial_burns=True), None, True, False),
    ],
)
def test_suspected_inhalation_signs_are_immediate(airway, breathing, enclosed, face):
    entries = [(R.head_anterior, 0.2, D.superficial)] if face else [(R.trunk_anterior, 0.1, D.superficial)]
    r = assess_referral(inputs(*entries, airway=airway, breathing=breathing, enclosed=enclosed))
    assert "aba2022.inhalation" in r.current.met
    assert criterion(r.current, "aba2022.inhalation").tier is ReferralTier.immediate
    assert r.current.recommendation == IMMEDIATE
    assert "aba2006.inhalation" in r.older.met


def test_carbonaceous_sputum_is_immediate():
    r = assess_referral(inputs((R.trunk_anterior, 0.1, D.superficial), airway=Airway(carbonaceous_sputum=True)))
    assert r.current.met == ["aba2022.inhalation"]
    assert criterion(r.current, "aba2022.inhalation").reason == "carbonaceous sputum"
    assert r.current.recommendation == IMMEDIATE


@pytest.mark.parametrize(
    "airway, enclosed, face, mechanism, sign",
    [
        (Airway(facial_burns=True), True, False, M.flame, "facial burns"),
        (None, True, True, M.flame, "facial burns"),  # facial burn on the chart, enclosed space
        (Airway(singed_nasal_hair=True), False, False, M.flame, "singed facial or nasal hair"),
        (None, True, False, M.flame, "smoke exposure (flame burn in an enclosed space)"),
        (None, False, True, M.flame, "facial burns"),  # a facial flash burn outdoors
    ],
)
def test_potential_inhalation_signs_need_consultation(airway, enclosed, face, mechanism, sign):
    entries = [(R.head_anterior, 0.2, D.superficial)] if face else [(R.trunk_anterior, 0.1, D.superficial)]
    r = assess_referral(inputs(*entries, airway=airway, enclosed=enclosed, mechanism=mechanism))
    assert r.current.met == ["aba2022.inhalation_potential"]
    potential = criterion(r.current, "aba2022.inhalation_potential")
    assert potential.tier is ReferralTier.consult
    assert sign in potential.reason
    assert criterion(r.current, "aba2022.inhalation").met is False
    assert r.current.recommendation == CONSULT


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


def test_enclosed_space_scald_is_not_smoke_exposure():
    r = assess_referral(inputs((R.trunk_anterior, 0.1, D.superficial), enclosed=True, mechanism=M.scald))
    assert criterion(r.current, "aba2022.inhalation_potential").met is False


def test_inhalation_undetermined_without_primary_survey():
    r = assess_referral(inputs((R.trunk_anterior, 0.1, D.superficial), with_primary=False))
    assert criterion(r.current, "aba2022.inhalation").met is None
    assert criterion(r.current, "aba2022.inhalation_potential").met is None
    assert "singed hair" in criterion(r.current, "aba2022.inhalation_potential").reason
    # smoke exposure is still read from the mechanism
    smoke = assess_referral(inputs((R.trunk_anterior, 0.1, D.superficial), with_primary=False, enclosed=True))
    assert criterion(smoke.current, "aba2022.inhalation_potential").met is True


def test_no_inhalation_signs():
    r = assess_referral(
        inputs((R.trunk_anterior, 0.1, D.superficial_partial), breathing=Breathing(carboxyhaemoglobin_percent=8))
    )
    assert criterion(r.current, "aba2022.inhalation").met is False


def test_low_voltage_electrical():
    r = assess_referral(inputs((R.hand_left_palmar, 0.2, D.superficial), mechanism=M.electrical_low_voltage))
    assert r.current.met == ["aba2022.low_voltage"]
    assert r.current.recommendation == CONSULT
    assert "aba2006.electrical" in r.older.met


@pytest.mark.parametrize(
    "mechanism, voltage", [(M.electrical_high_voltage, None), (M.lightning, None), (M.electrical_low_voltage, 11_000)]
)
def test_high_voltage_and_lightning_are_immediate(mechanism, voltage):
    r = assess_referral(inputs((R.hand_left_palmar, 0.2, D.superficial), mechanism=mechanism, voltage=voltage))
    assert "aba2022.high_voltage" in r.current.met
    assert "aba2022.low_voltage" not in r.current.met
    assert r.current.recommendation == IMMEDIATE


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
    assert "aba2022.full_thickness" in r.current.recommendation


def test_chart_without_age_decides_depth_but_not_size():
    r = assess_referral(
        inputs((R.thigh_left_anterior, 0.5, D.full_thickness), (R.trunk_anterior, 0.5, D.deep_partial), age=None)
    )
    assert "aba2022.full_thickness" in r.current.met
    assert criterion(r.current, "aba2022.partial_ge_10").met is None
    assert "age" in criterion(r.current, "aba2022.partial_ge_10").reason


def test_concomitant_trauma():
    entries = [(R.trunk_anterior, 0.1, D.superficial_partial)]
    unknown = assess_referral(inputs(*entries, injuries=["open femur fracture"]))
    assert "aba2022.trauma" in unknown.current.met
    older = criterion(unknown.older, "aba2006.trauma")
    assert older.met is None
    assert "record whether the burn or the trauma is the greater risk" in older.reason
    assert (
        "aba2006.trauma" in assess_referral(inputs(*entries, injuries=["rib fractures"], burn_greatest=True)).older.met
    )
    trauma_first = assess_referral(inputs(*entries, injuries=["rib fractures"], burn_greatest=False))
    assert criterion(trauma_first.older, "aba2006.trauma").met is False


def test_comorbidity_is_immediate():
    r = assess_referral(inputs((R.trunk_anterior, 0.1, D.superficial), comorbidities=["diabetes mellitus"]))
    assert r.current.met == ["aba2022.comorbidities"]
    assert criterion(r.current, "aba2022.comorbidities").tier is ReferralTier.immediate
    assert criterion(r.current, "aba2022.comorbidities").reason == "significant comorbidities: diabetes mellitus"
    assert r.current.recommendation == IMMEDIATE
    assert "aba2006.comorbidities" in r.older.met


def test_concomitant_trauma_is_immediate():
    r = assess_referral(inputs((R.trunk_anterior, 0.1, D.superficial), injuries=["open femur fracture"]))
    assert r.current.met == ["aba2022.trauma"]
    assert criterion(r.current, "aba2022.trauma").tier is ReferralTier.immediate
    assert r.current.recommendation == IMMEDIATE


def test_social_needs_are_only_on_the_older_list():
    # the ABA 2022 table has no row for special social, emotional or rehabilitative needs
    r = assess_referral(
        inputs((R.trunk_anterior, 0.1, D.superficial), social=SocialContext(substance_use=True, notes="lives alone"))
    )
    assert r.current.met == []
    assert all("social" not in c.code for c in r.current.criteria)
    assert r.older.met == ["aba2006.special_needs"]


def test_child_with_safeguarding_concern_is_immediate():
    r = assess_referral(
        inputs(
            (R.buttock_left, 0.4, D.superficial_partial),
            age=2,
            weight=12,
            mechanism=M.scald,
            social=SocialContext(safeguarding_concern=True),
        )
    )
    assert "aba2022.pediatric" in r.current.met
    assert "safeguarding concern recorded (possible non-accidental trauma)" in (
        criterion(r.current, "aba2022.pediatric").reason
    )
    assert r.current.recommendation == IMMEDIATE
    assert "aba2006.special_needs" in r.older.met


def test_child_with_safeguarding_concern_but_no_chart_is_immediate():
    r = assess_referral(
        ReferralInputs(
            age_years=2,
            weight_kg=12,
            intake=Intake(encounter_id=EID, social=SocialContext(safeguarding_concern=True)),
        )
    )
    assert criterion(r.current, "aba2022.pediatric").met is True
    assert r.current.recommendation == IMMEDIATE


def test_deep_partial_3_percent_forearm_adult_is_potentially_deep():
    # adult right lower arm 1.5 + 1.5 = 3 %TBSA deep partial: not a critical area
    r = assess_referral(
        inputs((R.lower_arm_right_anterior, 1.0, D.deep_partial), (R.lower_arm_right_posterior, 1.0, D.deep_partial))
    )
    assert set(r.current.met) == {"aba2022.partial_lt_10", "aba2022.potentially_deep"}
    deep = criterion(r.current, "aba2022.potentially_deep")
    assert deep.tier is ReferralTier.consult
    assert deep.reason == (
        "deep partial-thickness burns 3.00 %TBSA (lower_arm_right_anterior, lower_arm_right_posterior): "
        "potentially deep"
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


def test_poorly_controlled_pain():
    entries = [(R.trunk_anterior, 0.1, D.superficial)]
    poor = assess_referral(inputs(*entries, pain=True))
    assert poor.current.met == ["aba2022.pain"]
    assert criterion(poor.current, "aba2022.pain").tier is ReferralTier.immediate
    assert poor.current.recommendation == IMMEDIATE
    unknown = assess_referral(inputs(*entries, pain=None))
    pain = criterion(unknown.current, "aba2022.pain")
    assert pain.met is None
    assert pain.reason == "record whether pain is controlled"
    assert unknown.current.undetermined == ["aba2022.pain"]
    assert unknown.current.recommendation == (
        "No ABA referral criterion met on the recorded data; not assessable from the record: aba2022.pain"
    )
    no_survey = criterion(assess_referral(inputs(*entries, with_primary=False)).current, "aba2022.pain")
    assert no_survey.met is None
    assert "record whether pain is controlled" in no_survey.reason
    assert criterion(assess_referral(inputs(*entries)).current, "aba2022.pain").met is False


def test_consultation_names_open_immediate_criteria():
    r = assess_referral(inputs((R.lower_arm_left_anterior, 0.5, D.superficial_partial), pain=None))
    assert r.current.met == ["aba2022.partial_lt_10"]
    assert r.current.recommendation == f"{CONSULT}; not assessable from the record: aba2022.pain"


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
