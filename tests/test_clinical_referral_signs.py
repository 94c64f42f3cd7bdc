"""Burn-center referral by mechanism, airway signs, injuries, comorbidity, pain and social needs."""

from __future__ import annotations

import pytest

from processing.clinical.referral import ReferralInputs, assess_referral
from schemas.burn_chart import BurnDepth as D
from schemas.burn_chart import LundBrowderRegion as R
from schemas.clinical_results import ReferralTier
from schemas.record_parts import Airway, AirwayIntervention, Breathing, Intake, SocialContext
from schemas.record_parts import MechanismType as M
from tests.referral_cases import CONSULT, EID, IMMEDIATE, criterion, inputs


def test_chemical_is_immediate_in_both():
    r = assess_referral(inputs((R.lower_arm_left_anterior, 0.5, D.superficial_partial), mechanism=M.chemical))
    assert "aba2022.chemical" in r.current.met
    assert r.current.recommendation == IMMEDIATE
    assert "aba2006.chemical" in r.older.met


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
        "No ABA referral criterion met on the recorded data; not assessable from the record: Thermal: poorly controlled pain"
    )
    no_survey = criterion(assess_referral(inputs(*entries, with_primary=False)).current, "aba2022.pain")
    assert no_survey.met is None
    assert "record whether pain is controlled" in no_survey.reason
    assert criterion(assess_referral(inputs(*entries)).current, "aba2022.pain").met is False
