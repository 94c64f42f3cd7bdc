"""Where an assessment's inputs came from, and what limits them: its provenance and caveats lines.

Factual only: each line says which record a value came from and how it was obtained, so an
estimated weight or age is never hidden behind a precise-looking figure.
"""

from __future__ import annotations

from processing.clinical.checks import member
from schemas.base import iso
from schemas.burn_chart import BurnChart
from schemas.patient import Encounter, Patient, WeightSource


def num(value: object) -> str:
    """A number as written in provenance lines (repr for anything that is not one)."""
    return f"{value:g}" if isinstance(value, (int, float)) and not isinstance(value, bool) else repr(value)


def age_notes(patient: Patient, encounter: Encounter, age: float) -> tuple[str, list[str]]:
    """Provenance line and caveats of the age used."""
    if patient.date_of_birth is not None:
        when = (
            "at the time of injury"
            if encounter.time_of_injury is not None
            else "on the day of arrival (time of injury not recorded)"
        )
        return f"age {age:.1f} y from date of birth {patient.date_of_birth.isoformat()} {when}", []
    caveat = (
        f"age estimated ({num(patient.age_estimate_years)} y), not from a date of birth: the Lund-Browder column "
        "and the child rules (fluids, referral) may be wrong for a child or adolescent if the estimate is"
    )
    return f"age {num(patient.age_estimate_years)} y as estimated (no date of birth)", [caveat]


def weight_used(patient: Patient, encounter: Encounter) -> tuple[float | None, str, str, list[str]]:
    """The weight the calculators use, its FluidPlan.weight_source, provenance line and caveats."""
    if encounter.weight_kg is not None:
        # Only the patient's weight records how it was obtained; an encounter weight does not.
        weight, how, where = encounter.weight_kg, None, "encounter"
    elif patient.weight_kg is not None:
        weight, how, where = patient.weight_kg, patient.weight_source, "patient record"
    else:
        return None, "not recorded", "weight not recorded", []
    how = member(WeightSource, how, "weight source").value if how is not None else None
    where_long = "this encounter" if where == "encounter" else "the patient record"
    line = f"weight {num(weight)} kg {how or '(how it was obtained is not recorded)'}, from {where_long}"
    if where == "encounter" and patient.weight_kg is not None and patient.weight_kg != weight:
        line += f" (the patient record's {num(patient.weight_kg)} kg is not used)"
    caveats = []
    if how != WeightSource.measured.value:
        what = {
            WeightSource.estimated.value: "weight was estimated",
            WeightSource.reported.value: "weight was reported, not measured",
        }.get(how, "how the weight was obtained is not recorded")
        caveats.append(f"{what}: fluid volumes and body surface area are only as good as the weight")
    return weight, f"{how or 'not recorded'}, {where}", line, caveats


def chart_notes(chart: BurnChart, encounter: Encounter) -> tuple[str, list[str]]:
    """Provenance line and caveats of the chart the %TBSA comes from."""
    line = f"%TBSA from the burn chart assessed at {iso(chart.assessed_at)}"
    if encounter.time_of_injury is None:
        return line, []
    hours = (chart.assessed_at - encounter.time_of_injury).total_seconds() / 3600
    if hours < 0:
        return line, [
            f"the burn chart was assessed {-hours:.1f} h before the recorded time of injury: check both times"
        ]
    return f"{line}, {hours:.1f} h after injury", []
