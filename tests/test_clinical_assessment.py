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


def run(p=None, e=None, parts=None) -> Assessment:
    return assess(
        patient=p or patient(),
        encounter=e or encounter(),
        parts=full_parts() if parts is None else parts,
        inputs=[InputRef(kind="burn_chart", id=EID, version=3)],
        as_of=AS_OF,
        config=CONFIG,
        computed_at=AS_OF + dt.timedelta(seconds=5),
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
    assert a.inputs[0].version == 3
    # the result is a storable record
    assert msgspec.json.decode(msgspec.json.encode(a), type=Assessment) == a


def test_encounter_weight_overrides_patient_weight_and_formula_is_taken_from_resuscitation():
    parts = full_parts()
    parts[RecordKind.resuscitation] = Resuscitation(encounter_id=EID, formula=FluidFormula.abls)
    a = run(e=encounter(weight_kg=80.0), parts=parts)
    assert a.weight_kg == 80
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


@pytest.mark.parametrize(
    "p, e",
    [
        (patient(date_of_birth=dt.date(2025, 1, 1)), None),  # born after the injury
        (patient(date_of_birth=None, age_estimate_years=200.0), None),
        (None, encounter(weight_kg=0.0)),
        (None, encounter(time_of_injury=AS_OF + dt.timedelta(hours=3))),  # injury after as_of
        (None, encounter(patient_id="0192f3b4-6a8e-7c3d-9b1a-000000000009")),
    ],
)
def test_impossible_data_propagates(p, e):
    with pytest.raises(InvalidInput):
        run(p=p, e=e)


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
