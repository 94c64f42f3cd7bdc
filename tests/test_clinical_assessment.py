"""The whole calculator run on an encounter: a realistic full record, a sparse one, bad data."""

from __future__ import annotations

import datetime as dt

import msgspec
import pytest

from processing.clinical.assessment import assess
from schemas.burn_chart import BurnChart, BurnChartEntry
from schemas.burn_chart import BurnDepth as D
from schemas.burn_chart import LundBrowderRegion as R
from schemas.clinical_results import Assessment, FluidPhase, InputRef
from schemas.config import ClinicalConfig
from schemas.errors import InvalidInput
from schemas.patient import Encounter, EncounterMode, Patient
from schemas.record_parts import (
    FluidFormula,
    FluidGiven,
    Intake,
    Mechanism,
    MechanismType,
    PrimarySurvey,
    Resuscitation,
    SecondarySurvey,
)
from schemas.records import RecordKind

UTC = dt.UTC
PID = "0192f3b4-6a8e-7c3d-9b1a-000000000001"
EID = "0192f3b4-6a8e-7c3d-9b1a-000000000002"
INJURY = dt.datetime(2024, 3, 1, 8, 0, tzinfo=UTC)
ARRIVAL = INJURY + dt.timedelta(hours=1, minutes=30)
AS_OF = INJURY + dt.timedelta(hours=2)
CONFIG = ClinicalConfig()
RIGHT_ARM = [r for r in R if r.value.startswith(("upper_arm_right", "lower_arm_right", "hand_right"))]


def patient(**kw) -> Patient:
    base = dict(id=PID, date_of_birth=dt.date(1990, 6, 15), weight_kg=70.0, height_cm=175.0)
    base.update(kw)
    return Patient(**base)


def encounter(**kw) -> Encounter:
    base = dict(id=EID, patient_id=PID, mode=EncounterMode.emergency, time_of_arrival=ARRIVAL, time_of_injury=INJURY)
    base.update(kw)
    return Encounter(**base)


def burn_chart(encounter_id=EID) -> BurnChart:
    # adult: anterior trunk 13 deep partial + right arm 9.5 superficial partial + right thigh front 4.75 full
    entries = [BurnChartEntry(region=R.trunk_anterior, fraction=1.0, depth=D.deep_partial)]
    entries += [BurnChartEntry(region=r, fraction=1.0, depth=D.superficial_partial) for r in RIGHT_ARM]
    entries.append(BurnChartEntry(region=R.thigh_right_anterior, fraction=1.0, depth=D.full_thickness))
    return BurnChart(encounter_id=encounter_id, assessed_at=ARRIVAL, entries=entries)


def full_parts() -> dict:
    return {
        RecordKind.intake: Intake(encounter_id=EID),
        RecordKind.primary_survey: PrimarySurvey(encounter_id=EID, assessed_at=ARRIVAL),
        RecordKind.secondary_survey: SecondarySurvey(encounter_id=EID, assessed_at=ARRIVAL),
        RecordKind.mechanism: Mechanism(encounter_id=EID, type=MechanismType.flame),
        RecordKind.burn_chart: burn_chart(),
        RecordKind.resuscitation: Resuscitation(
            encounter_id=EID,
            fluid_given=[FluidGiven(volume_ml=1_000, given_at=INJURY + dt.timedelta(hours=1, minutes=45))],
        ),
    }


def run(p=None, e=None, parts=None, as_of=AS_OF, clock_skew_s=300) -> Assessment:
    return assess(
        patient=p or patient(),
        encounter=e or encounter(),
        parts=full_parts() if parts is None else parts,
        inputs=[InputRef(kind="burn_chart", id=EID, version=3)],
        as_of=as_of,
        config=CONFIG,
        computed_at=as_of + dt.timedelta(seconds=5),
        clock_skew_s=clock_skew_s,
    )


def test_full_record():
    a = run()
    # born 1990-06-15, injured 2024-03-01: 33 years and 260 days -> 33.71 years
    assert a.age_years == pytest.approx(33.71, abs=0.01)
    assert a.weight_kg == 70
    # 13 + 9.5 + 4.75 = 27.25 %TBSA
    assert a.tbsa.tbsa_percent == 27.25
    assert a.tbsa.full_thickness_percent == 4.75
    # sqrt(175 x 70 / 3600) = 1.8447
    assert a.bsa.bsa_m2 == pytest.approx(1.845, abs=0.001)
    # Parkland 4 x 70 x 27.25 = 7,630 mL; 3,815 in 8 h; 2 h in, 1,000 given: 2,815 / 6 = 469.2 mL/h
    assert a.fluids.total_24h_ml == 7_630
    assert a.fluids.phase is FluidPhase.first_8h
    assert a.fluids.rate_now_ml_per_h == 469.2
    assert a.referral.current.recommendation == "Immediate consultation with consideration for transfer"
    assert "aba2022.full_thickness" in a.referral.current.met
    assert a.missing == []
    assert a.calculator_errors == []
    assert a.inputs[0].version == 3
    assert a.tbsa.age_source == "date_of_birth"
    assert a.fluids.weight_source == "not recorded, patient record"
    assert a.provenance == [
        "age 33.7 y from date of birth 1990-06-15 at the time of injury",
        "weight 70 kg (how it was obtained is not recorded), from the patient record",
        "%TBSA from the burn chart assessed at 2024-03-01T09:30:00.000000+00:00, 1.5 h after injury",
        "height 175 cm, from the patient record",
    ]
    assert a.caveats == [
        "how the weight was obtained is not recorded: fluid volumes and body surface area are only as good as "
        "the weight"
    ]
    # the result is a storable record
    assert msgspec.json.decode(msgspec.json.encode(a), type=Assessment) == a


def test_encounter_weight_overrides_patient_weight_and_formula_is_taken_from_resuscitation():
    parts = full_parts()
    parts[RecordKind.resuscitation] = Resuscitation(encounter_id=EID, formula=FluidFormula.abls)
    a = run(e=encounter(weight_kg=80.0), parts=parts)
    assert a.weight_kg == 80
    assert a.fluids.weight_source == "not recorded, encounter"
    assert (
        "weight 80 kg (how it was obtained is not recorded), from this encounter (the patient record's 70 kg is not used)"
        in a.provenance
    )
    # ABLS adult thermal 2 x 80 x 27.25 = 4,360 mL
    assert a.fluids.total_24h_ml == 4_360
    assert a.fluids.formula is FluidFormula.abls


def test_sparse_record():
    sparse = Patient(id=PID)
    a = run(p=sparse, e=encounter(time_of_injury=None), parts={})
    assert a.age_years is None and a.weight_kg is None
    assert a.tbsa is None and a.bsa is None and a.fluids is None
    assert a.referral is not None
    assert "aba2022.full_thickness" in a.referral.current.undetermined
    text = " | ".join(a.missing)
    for needed in ("date of birth or estimated age", "weight", "burn chart", "height", "time of injury"):
        assert needed in text


def test_estimated_age_without_injury_time():
    p = patient(date_of_birth=None, age_estimate_years=4.0, weight_kg=16.0, height_cm=100.0)
    a = run(p=p, e=encounter(time_of_injury=None))
    assert a.age_years == 4
    # 1-year column: trunk 13 + upper arm 4 + lower arm 3 + hand 2.5 + thigh front 6.5 / 2 = 25.75
    assert a.tbsa.tbsa_percent == 25.75
    assert a.bsa.bsa_m2 == 0.667
    assert a.fluids is None
    assert a.missing == ["time of injury (needed for the fluid plan)"]
    assert "aba2022.pediatric" in a.referral.current.met


def test_age_from_arrival_date_without_injury_time():
    # born 2020-03-01, arrived 2024-03-01: 1,461 days / 365.25 = 4.0 years
    a = run(p=patient(date_of_birth=dt.date(2020, 3, 1)), e=encounter(time_of_injury=None))
    assert a.age_years == 4.0
    assert (
        a.provenance[0] == "age 4.0 y from date of birth 2020-03-01 on the day of arrival (time of injury not recorded)"
    )
    # no injury time: the chart's delay after injury cannot be given
    assert "%TBSA from the burn chart assessed at 2024-03-01T09:30:00.000000+00:00" in a.provenance


def test_measured_weight_and_estimated_age_are_stated():
    from schemas.patient import WeightSource

    p = patient(date_of_birth=None, age_estimate_years=40.0, weight_kg=62.0, weight_source=WeightSource.measured)
    a = run(p=p)
    assert a.tbsa.age_source == "estimate"
    assert a.fluids.weight_source == "measured, patient record"
    assert a.provenance[:2] == [
        "age 40 y as estimated (no date of birth)",
        "weight 62 kg measured, from the patient record",
    ]
    assert len(a.caveats) == 1 and a.caveats[0].startswith("age estimated (40 y), not from a date of birth")


def test_estimated_weight_is_a_caveat():
    from schemas.patient import WeightSource

    a = run(p=patient(weight_source=WeightSource.estimated))
    assert "weight 70 kg estimated, from the patient record" in a.provenance
    assert a.fluids.weight_source == "estimated, patient record"
    assert a.caveats == ["weight was estimated: fluid volumes and body surface area are only as good as the weight"]


def test_chart_assessed_before_the_injury_is_a_caveat():
    parts = full_parts()
    chart = burn_chart()
    parts[RecordKind.burn_chart] = BurnChart(
        encounter_id=EID, assessed_at=INJURY - dt.timedelta(minutes=30), entries=chart.entries
    )
    a = run(parts=parts)
    assert "the burn chart was assessed 0.5 h before the recorded time of injury: check both times" in a.caveats


def test_assess_needs_the_clock_skew():
    with pytest.raises(TypeError, match="clock_skew_s"):
        assess(
            patient=patient(), encounter=encounter(), parts={}, inputs=[], as_of=AS_OF, config=CONFIG, computed_at=AS_OF
        )


def test_configured_clock_skew_is_passed_to_the_fluid_plan():
    # injury recorded 4 min after as_of: clock drift within 300 s (0 h), an error with no tolerance
    e = encounter(time_of_injury=AS_OF + dt.timedelta(minutes=4))
    assert run(e=e, clock_skew_s=300).fluids.hours_since_injury == 0
    strict = run(e=e, clock_skew_s=0)
    assert strict.fluids is None
    assert len(strict.calculator_errors) == 1
    assert strict.calculator_errors[0].startswith(
        "fluid plan: time of injury 2024-03-01T10:04:00.000000+00:00 is after"
    )
    with pytest.raises(InvalidInput, match="clock skew"):
        run(clock_skew_s=-1)


def test_bad_resuscitation_blocks_only_the_fluid_plan():
    parts = full_parts()
    parts[RecordKind.resuscitation] = Resuscitation(encounter_id=EID, formula=FluidFormula.custom)
    a = run(parts=parts)
    assert a.fluids is None
    assert a.calculator_errors == [
        "fluid plan: resuscitation: custom fluid formula chosen but no mL/kg/%TBSA given: enter it (up to 8) "
        "($.custom_ml_per_kg_per_percent)"
    ]
    assert a.tbsa.tbsa_percent == 27.25 and a.bsa.bsa_m2 == 1.845
    assert a.referral.current.recommendation == "Immediate consultation with consideration for transfer"
    assert a.missing == []


def test_bad_chart_blocks_tbsa_and_the_fluid_plan_only():
    parts = full_parts()
    entries = [BurnChartEntry(region=R.genitalia, fraction=0.2, depth=D.deep_partial)] * 2
    parts[RecordKind.burn_chart] = BurnChart(encounter_id=EID, assessed_at=ARRIVAL, entries=entries)
    a = run(parts=parts)
    assert a.tbsa is None and a.fluids is None
    assert a.calculator_errors[0].startswith("%TBSA: burn chart: Genitalia is charted twice at depth deep_partial")
    assert a.calculator_errors[1] == (
        "fluid plan: not computed: needs the %TBSA, which could not be worked out (see %TBSA)"
    )
    assert a.bsa.bsa_m2 == 1.845
    # the referral criteria still read the chart: deep partial-thickness genitalia is a critical area
    assert "aba2022.critical_areas_deep" in a.referral.current.met


def test_date_of_birth_after_injury_is_an_age_error_not_missing_data():
    a = run(p=patient(date_of_birth=dt.date(2025, 1, 1)))
    assert a.age_years is None and a.tbsa is None and a.fluids is None
    assert a.calculator_errors == [
        "age: date of birth 2025-01-01 is after the injury (2024-03-01): check the date of birth",
        "%TBSA: not computed: needs the age, which could not be worked out (see age)",
        "fluid plan: not computed: needs the %TBSA, which could not be worked out (see %TBSA)",
    ]
    assert a.missing == []
    assert a.bsa.bsa_m2 == 1.845
    assert "aba2022.full_thickness" in a.referral.current.met


def test_impossible_weight_blocks_bsa_and_fluids_not_tbsa():
    a = run(e=encounter(weight_kg=0.0))
    assert a.weight_kg is None and a.bsa is None and a.fluids is None
    assert a.calculator_errors == [
        "weight: weight 0 kg is impossible: enter a number above 0, up to 400 kg",
        "body surface area: not computed: needs the weight, which could not be worked out (see weight)",
        "fluid plan: not computed: needs the weight, which could not be worked out (see weight)",
    ]
    assert a.tbsa.tbsa_percent == 27.25
    # an impossible weight does not make the adult a child (< 30 kg) for the referral criteria
    assert "aba2022.pediatric" not in a.referral.current.met


def test_impossible_age_estimate_is_an_age_error():
    a = run(p=patient(date_of_birth=None, age_estimate_years=200.0))
    assert a.calculator_errors[0] == "age: age 200 years is impossible: enter a number from 0 to 130 years"
    assert a.tbsa is None


def test_injury_after_as_of_is_a_fluid_plan_error():
    a = run(e=encounter(time_of_injury=AS_OF + dt.timedelta(hours=3)))
    assert a.fluids is None
    assert [e.split(":")[0] for e in a.calculator_errors] == ["fluid plan"]
    assert a.tbsa is not None and a.bsa is not None


def test_encounter_of_another_patient_is_rejected():
    with pytest.raises(InvalidInput, match="belongs to patient"):
        run(e=encounter(patient_id="0192f3b4-6a8e-7c3d-9b1a-000000000009"))


@pytest.mark.parametrize("kind", [RecordKind.patient, RecordKind.encounter, RecordKind.assessment, "tattoo"])
def test_a_kind_that_is_not_an_encounter_part_is_rejected(kind):
    parts = full_parts()
    parts[kind] = patient() if kind is RecordKind.patient else encounter()
    with pytest.raises(InvalidInput, match="is not an encounter part"):
        run(parts=parts)


def test_part_kinds_may_be_given_as_plain_strings():
    parts = {kind.value: part for kind, part in full_parts().items()}
    assert run(parts=parts).fluids.total_24h_ml == 7_630


def test_part_of_another_encounter_is_rejected():
    parts = full_parts()
    parts[RecordKind.burn_chart] = burn_chart(encounter_id="0192f3b4-6a8e-7c3d-9b1a-000000000099")
    with pytest.raises(InvalidInput, match="burn_chart"):
        run(parts=parts)


def test_part_of_the_wrong_type_is_rejected():
    parts = full_parts()
    parts[RecordKind.burn_chart] = Intake(encounter_id=EID)
    with pytest.raises(InvalidInput, match="burn_chart"):
        run(parts=parts)
