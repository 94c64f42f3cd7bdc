"""The rules for a major burn against their sources' thresholds, on the issue's house-fire case and its variants."""

from __future__ import annotations

from types import SimpleNamespace

import msgspec
import pytest

from base.web.pages.rendering import environment
from gateway.site import TEMPLATE_DIRS
from processing.clinical import (
    airway,
    circulation,
    decision_support,
    mechanism_care,
    oxygen,
    pain,
    safeguarding,
    temperature,
    wound_care,
)
from schemas.record_parts import (
    Airway,
    AirwayIntervention,
    Allergy,
    Breathing,
    Circulation,
    Disability,
    Exposure,
    MechanismType,
    Medication,
    SocialContext,
)
from tests import major_burn_case as case


def _by_key(made):
    return {r.key: r for r in made}


def test_the_house_fire_case_gets_urgent_airway_oxygen_escharotomy_opioid_and_tetanus_first():
    made = decision_support.recommend(case.inputs(), computed_at=case.INJURY).recommendations
    urgent = [r.key for r in made if r.urgent]
    assert urgent[:3] == ["airway.inhalation", "breathing.oxygen", "circulation.limb"]
    assert {"tetanus", "pain.opioid", "fluids.plan", "follow_up.referral"} <= set(urgent)
    first_routine = next(i for i, r in enumerate(made) if not r.urgent)
    assert all(not r.urgent for r in made[first_routine:]), "urgent recommendations lead"
    recs = _by_key(made)
    assert "Apixaban 5 mg twice daily" in " ".join(recs["circulation.limb"].details)
    assert "morphine is not advised: allergy recorded to Morphine (rash and wheeze)" in recs["pain.opioid"].text
    assert "tetanus immune globulin" in recs["tetanus"].text
    for r in made:
        assert r.source.guideline and (r.source.year or r.source.accessed), r.key
        assert r.inputs, f"{r.key} names no input"


@pytest.mark.parametrize(
    ("sign", "expected"),
    [
        ({"hoarse_voice": True}, "hoarse voice"),
        ({"singed_nasal_hair": True}, "singed nasal hair"),
        ({"carbonaceous_sputum": True}, "carbonaceous sputum"),
        ({"stridor": True}, "Stridor is an immediate indication for intubation"),
    ],
)
def test_each_sign_of_inhalation_injury_calls_for_early_airway_assessment(sign, expected):
    inputs = case.with_part(case.inputs(mechanism=None), "primary", airway=Airway(**sign), breathing=Breathing())
    (made,), _ = airway.recommend(inputs)
    assert made.urgent and expected in made.text and "most experienced person" in made.text


def test_no_sign_no_airway_advice_and_a_secured_airway_is_not_assessed_again():
    quiet = case.with_part(case.inputs(mechanism=None), "primary", airway=Airway(), breathing=Breathing())
    assert airway.recommend(quiet) == ([], [])
    tubed = case.with_part(
        case.inputs(), "primary", airway=Airway(hoarse_voice=True, intervention=AirwayIntervention.intubated)
    )
    assert airway.recommend(tubed)[0] == []


def test_the_intubation_indications_met_are_stated_with_their_figures():
    inputs = case.with_part(case.inputs(), "primary", disability=Disability(gcs_eye=2, gcs_verbal=2, gcs_motor=4))
    (made,), _ = airway.recommend(inputs)
    assert "Recorded GCS 8: under 9" in " ".join(made.details)
    assert "40 %TBSA" not in made.details[0]  # 21.75 %: under the JTS figure


@pytest.mark.parametrize(
    ("cohb", "enclosed", "shown", "poisoned"),
    [(18.0, False, True, True), (10.0, False, False, False), (3.0, True, True, False), (None, True, True, False)],
)
def test_oxygen_for_a_raised_cohb_over_10_percent_or_an_enclosed_space_fire(cohb, enclosed, shown, poisoned):
    base = case.with_mechanism(case.inputs(), MechanismType.flame, enclosed_space=enclosed)
    inputs = case.with_part(base, "primary", airway=Airway(), breathing=Breathing(carboxyhaemoglobin_percent=cohb))
    made, missing = oxygen.recommend(inputs)
    assert bool(made) == shown
    if shown:
        assert made[0].urgent and "100 % high-flow oxygen (15 L/min" in made[0].text and "under 5 %" in made[0].text
        assert ("carbon monoxide poisoning)" in made[0].text) == poisoned
        assert "normal SpO2 does not rule out" in made[0].details[0]
        assert bool(missing) == (cohb is None)


def test_a_circumferential_deep_limb_burn_gets_hourly_checks_and_absent_pulses_make_it_urgent():
    with_pulses = case.with_part(case.inputs(), "primary", circulation=Circulation(distal_pulses_present=True))
    ((limb,),) = [[r for r in circulation.recommend(with_pulses)[0] if r.key == "circulation.limb"]]
    assert not limb.urgent and "hourly neurovascular checks" in limb.text and "Elevate the limb" in limb.details[1]
    (pulseless,) = [r for r in circulation.recommend(case.inputs())[0] if r.key == "circulation.limb"]
    assert pulseless.urgent and "consult the burn surgeon now about escharotomy" in pulseless.text
    superficial = case.inputs(chart=None)
    quiet = case.with_part(superficial, "primary", circulation=Circulation())
    assert circulation.recommend(quiet) == ([], [])


def test_the_anticoagulant_is_named_only_when_one_is_recorded():
    plain = case.with_part(case.inputs(), "intake", medications=[Medication(name="Metformin", dose="500 mg")])
    (limb,) = circulation.recommend(plain)[0]
    assert not any("Anticoagulant" in d for d in limb.details)
    warfarin = case.with_part(case.inputs(), "intake", medications=[Medication(name="warfarin")])
    (limb,) = circulation.recommend(warfarin)[0]
    assert "Anticoagulant recorded: warfarin." in limb.details[0]


def test_a_chest_burn_that_restricts_breathing_is_urgent():
    watch = case.with_part(case.inputs(), "primary", breathing=Breathing(circumferential_chest_burn=True))
    (chest,) = [r for r in circulation.recommend(watch)[0] if r.key == "breathing.chest_escharotomy"]
    assert not chest.urgent and "watch for restricted breathing" in chest.text
    tight = case.with_part(
        case.inputs(), "primary", breathing=Breathing(circumferential_chest_burn=True, chest_movement_restricted=True)
    )
    (chest,) = [r for r in circulation.recommend(tight)[0] if r.key == "breathing.chest_escharotomy"]
    assert chest.urgent and "chest escharotomy or urgent transfer" in chest.text


@pytest.mark.parametrize(
    ("celsius", "urgent", "stop_cooling"), [(36.4, False, False), (35.5, True, False), (34.8, True, True)]
)
def test_warmth_for_a_burn_over_20_percent_rewarming_under_36_and_no_cooling_under_35(celsius, urgent, stop_cooling):
    inputs = case.with_part(case.inputs(hours=1.5), "primary", exposure=Exposure(temperature_c=celsius))
    (warm,), _ = temperature.recommend(inputs)
    assert "21.75 %TBSA (over 20 %" in warm.text and warm.urgent == urgent
    assert ("Stop cooling" in warm.text) == stop_cooling
    cooling = [r.key for r in wound_care.recommend(inputs)[0]]
    assert ("wound_care.cooling" in cooling) == (not stop_cooling)


def test_adult_opioid_by_route_and_allergy():
    no_allergy = case.with_part(case.inputs(), "intake", allergies=[])
    opioid = _by_key(pain.recommend(no_allergy)[0])["pain.opioid"]
    assert "morphine 2-5 mg IV every 5 minutes, titrated" in opioid.text and opioid.urgent
    no_line = case.with_part(no_allergy, "primary", circulation=Circulation(iv_access=False))
    assert "gain IV access" in _by_key(pain.recommend(no_line)[0])["pain.opioid"].text


def test_no_opioid_for_a_small_burn_with_pain_controlled():
    small = case.inputs(mechanism=None, entries=case.chart_entries()[:1])
    quiet = case.with_part(small, "primary", airway=Airway(), breathing=Breathing())
    assert "pain.opioid" not in _by_key(pain.recommend(quiet)[0])


@pytest.mark.parametrize(
    ("weight", "expected"),
    [
        (20.0, "morphine 1-2 mg IV (0.05-0.1 mg/kg × 20 kg)"),
        (60.0, "morphine 3-5 mg IV (0.05-0.1 mg/kg × 60 kg (capped at the adult 5 mg))"),
    ],
)
def test_child_iv_morphine_per_kg_capped_at_the_adult_increment(weight, expected):
    child = case.aged(case.with_part(case.inputs(), "intake", allergies=[]), 9.0, weight)
    assert expected in _by_key(pain.recommend(child)[0])["pain.opioid"].text


def test_a_child_allergic_to_morphine_is_offered_the_sources_fentanyl():
    child = case.aged(case.inputs(), 9.0, 30.0)
    text = _by_key(pain.recommend(child)[0])["pain.opioid"].text
    assert "morphine is not advised" in text and "IV fentanyl instead: 15-50 microgram" in text
    opioid_allergic = case.with_part(child, "intake", allergies=[Allergy(substance="opioids")])
    assert "seek senior advice" in _by_key(pain.recommend(opioid_allergic)[0])["pain.opioid"].text


@pytest.mark.parametrize(
    ("kind", "voltage", "keys", "urgent"),
    [
        (MechanismType.electrical_low_voltage, 230.0, ["mechanism.electrical_heart"], False),
        (
            MechanismType.electrical_high_voltage,
            11000.0,
            ["mechanism.electrical_heart", "mechanism.electrical_urine"],
            True,
        ),
        (
            MechanismType.electrical_low_voltage,
            1000.0,
            ["mechanism.electrical_heart", "mechanism.electrical_urine"],
            True,
        ),
    ],
)
def test_electrical_injury_ecg_for_all_monitoring_and_urine_for_high_voltage(kind, voltage, keys, urgent):
    made, _ = mechanism_care.recommend(case.with_mechanism(case.inputs(), kind, voltage_v=voltage))
    assert [r.key for r in made] == keys
    assert "12-lead ECG now" in made[0].text and made[0].urgent == urgent
    if len(made) > 1:
        assert "75-100 mL/h until the urine clears" in made[1].text


def test_chemical_burn_irrigation_and_hydrofluoric_acid():
    acid = case.with_mechanism(case.inputs(), MechanismType.chemical, agent="sulphuric acid")
    made, _ = mechanism_care.recommend(acid)
    assert [r.key for r in made] == ["mechanism.chemical_irrigation"] and made[0].urgent
    assert "while the pain persists or until the skin's pH is normal" in made[0].text
    hf = case.with_mechanism(case.inputs(), MechanismType.chemical, agent="Hydrofluoric acid 70 %")
    made, _ = mechanism_care.recommend(hf)
    assert [r.key for r in made] == ["mechanism.chemical_irrigation", "mechanism.hydrofluoric_acid"]
    assert "calcium gluconate" in made[1].text and "ECG" in made[1].text and made[1].urgent


@pytest.mark.parametrize(
    ("mechanism", "social", "shown"),
    [
        ({"account_fits_injury": True, "pattern_of_concern": False}, False, False),
        ({"account_fits_injury": False, "pattern_of_concern": False}, False, True),
        ({"account_fits_injury": True, "pattern_of_concern": True}, False, True),
        ({"account_fits_injury": True, "pattern_of_concern": False, "child_independently_mobile": False}, False, True),
        ({"account_fits_injury": True, "pattern_of_concern": False}, True, True),
    ],
)
def test_safeguarding_for_a_child_worded_without_accusation(mechanism, social, shown):
    inputs = case.with_mechanism(case.aged(case.inputs(), 3.0), MechanismType.scald, **mechanism)
    inputs = case.with_part(inputs, "intake", social=SocialContext(safeguarding_concern=social))
    made, missing = safeguarding.recommend(inputs)
    assert bool(made) == shown and not missing
    if shown:
        assert "not a finding" in made[0].text and "abuse" not in made[0].text.lower()
    adult = case.with_part(case.inputs(), "mechanism", account_fits_injury=False)
    assert safeguarding.recommend(adult) == ([], [])


def test_a_childs_burn_without_the_safeguarding_questions_says_they_are_missing():
    child = case.aged(case.inputs(), 3.0)
    _, missing = safeguarding.recommend(child)
    assert missing and "safeguarding questions" in missing[0]


def test_the_encounter_page_lists_urgent_recommendations_first_even_from_an_older_stored_order():
    support = decision_support.recommend(case.inputs(), computed_at=case.INJURY)
    older = sorted(support.recommendations, key=lambda r: r.urgent)  # as a record stored before the ordering
    view = SimpleNamespace(decision_support=msgspec.structs.replace(support, recommendations=older))
    template = environment(TEMPLATE_DIRS).get_template("recommendations.html")
    nurse = SimpleNamespace(role=SimpleNamespace(value="nurse"))
    html = template.render(view=view, principal=nurse, csrf_token="x", act_problem=None, act_reason="")
    shown = [line.split('data-key="')[1].split('"')[0] for line in html.splitlines() if 'data-key="' in line]
    urgent = {r.key for r in older if r.urgent}
    assert set(shown[: len(urgent)]) == urgent and shown[0] == "airway.inhalation"
