"""Shared builders for the referral tests: a chart, a full set of referral inputs, a criterion lookup."""

from __future__ import annotations

import datetime as dt

from processing.clinical.lund_browder import compute_tbsa
from processing.clinical.referral import ReferralInputs
from schemas.burn_chart import BurnChart, BurnChartEntry, SpecialAreaInvolvement
from schemas.record_parts import (
    Airway,
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
