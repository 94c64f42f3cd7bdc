"""Tetanus prophylaxis in wound management: the CDC/ACIP table, applied to a burn.

The table has two rows (prior doses of tetanus-toxoid-containing vaccine: unknown or fewer than three; three or
more) and two wound columns (clean and minor; all other wounds). A burn is one of "all other wounds". Each cell
gives whether a tetanus-toxoid-containing vaccine and whether tetanus immune globulin (TIG) are indicated; for
three or more doses the vaccine depends on the years since the last dose (10 for clean minor wounds, 5 for all
others). Sources and the checked wording are in docs/clinical.md.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from processing.clinical.decision_inputs import DecisionInputs
from processing.clinical.sources import ACIP_TETANUS
from schemas.decision_support import InputUsed, Recommendation, RecommendationCategory
from schemas.record_parts import TetanusDoses, TetanusStatus

DAYS_PER_YEAR = 365.25
TIG_DOSE = (
    "Tetanus immune globulin intramuscularly; dose per the product's label (the sources differ: 250 units in CDC's "
    "summary guide, 500 units for adults in the MSD Manual 2023)"
)


class Wound(enum.StrEnum):
    clean_minor = "clean_minor"
    other = "other"
    """Contaminated, puncture, avulsion, crush, missile, burn or frostbite wounds: every burn."""


YEARS_BEFORE_BOOSTER = {Wound.clean_minor: 10.0, Wound.other: 5.0}


@dataclass(frozen=True)
class TableCell:
    vaccine: bool | None
    """None: three or more doses but the time since the last is unknown, so the table cannot say."""
    tig: bool
    row: str
    why: str


def table_cell(doses: TetanusDoses, years_since_last: float | None, wound: Wound) -> TableCell:
    """The CDC/ACIP wound-management table, one cell."""
    if doses is not TetanusDoses.three_or_more:
        row = "unknown or fewer than 3 prior doses"
        return TableCell(vaccine=True, tig=wound is Wound.other, row=row, why=row)
    row = "3 or more prior doses"
    limit = YEARS_BEFORE_BOOSTER[wound]
    if years_since_last is None:
        return TableCell(None, False, row, f"{row}, time since the last dose not recorded")
    due = years_since_last >= limit
    side = "or more" if due else "fewer"
    return TableCell(due, False, row, f"{row}, last dose {years_since_last:.1f} years ago ({limit:g} {side})")


def _vaccine_for(age: float | None, cell: TableCell) -> str:
    if age is None:
        return "a tetanus-toxoid-containing vaccine for the patient's age (age not recorded)"
    if age < 7:
        return "DTaP (under 7 years)"
    if cell.row.startswith("unknown") or age >= 11:
        # Not fully immunised from 7 years, or 11 and over without a Tdap dose before: one dose of Tdap.
        return "Tdap (or Td if Tdap was given before)"
    return "Td or Tdap"


def _history(inputs: DecisionInputs) -> tuple[TableCell, list[InputUsed], list[str]]:
    """The table cell for this burn, with the facts used and what is missing."""
    intake = inputs.intake
    if intake is None:
        missing = ["tetanus history (intake not recorded): unknown counts as fewer than 3 doses in the table"]
        return table_cell(TetanusDoses.unknown, None, Wound.other), [], missing
    value = intake.value
    used, missing, years = [], [], None
    if value.last_tetanus_dose is not None:
        used.append(intake.used("last tetanus dose", value.last_tetanus_dose))
        years = _years(inputs)
    elif value.years_since_last_tetanus_dose is not None:
        used.append(intake.used("years since the last tetanus dose", value.years_since_last_tetanus_dose))
        years = value.years_since_last_tetanus_dose
    doses = value.tetanus_doses
    if doses is TetanusDoses.unknown and value.tetanus_status is TetanusStatus.never_immunised:
        used.insert(0, intake.used("tetanus status (older form)", value.tetanus_status))
        doses = TetanusDoses.fewer_than_three
    elif doses is TetanusDoses.unknown and value.tetanus_status is TetanusStatus.up_to_date and years is None:
        # The older form's documented meaning: immunised, last dose within 5 years.
        used.insert(0, intake.used("tetanus status (older form)", "up to date: last dose within 5 years"))
        row = "3 or more prior doses"
        return TableCell(False, False, row, f"{row}, recorded as up to date (last dose within 5 years)"), used, []
    else:
        used.insert(0, intake.used("prior tetanus doses", doses))
    if doses is TetanusDoses.unknown:
        missing.append("number of prior tetanus doses: unknown counts as fewer than 3 in the table")
    elif doses is TetanusDoses.three_or_more and years is None:
        missing.append("date of (or years since) the last tetanus dose: the table needs it for 3 or more doses")
    return table_cell(doses, years, Wound.other), used, missing


def _years(inputs: DecisionInputs) -> float:
    injury = inputs.injury_time or inputs.encounter.value.time_of_arrival
    days = (injury.date() - inputs.intake.value.last_tetanus_dose).days
    return max(days, 0) / DAYS_PER_YEAR


def recommend(inputs: DecisionInputs) -> tuple[list[Recommendation], list[str]]:
    cell, used, missing = _history(inputs)
    age = inputs.age_used()
    facts = [*used, *([age] if age else [])]
    vaccine = _vaccine_for(inputs.age_years, cell)
    immunodeficient = inputs.intake is not None and inputs.intake.value.severe_immunodeficiency
    tig = cell.tig or bool(immunodeficient)
    if immunodeficient:
        facts.append(inputs.intake.used("HIV infection or severe immunodeficiency", True))
    if cell.vaccine is None:
        text = (
            f"Tetanus: {cell.why}. If it was 5 or more years ago, give {vaccine}; if fewer, no vaccine is needed. "
            "Record the date of the last dose."
        )
    elif cell.vaccine:
        text = f"Tetanus: give {vaccine}; a burn counts among 'all other wounds' in the table ({cell.why})."
    else:
        text = f"Tetanus: no vaccine needed now; a burn counts among 'all other wounds' in the table ({cell.why})."
    details = []
    if tig:
        why = "severe immunodeficiency, whatever the vaccine history" if not cell.tig else cell.row
        text += f" Give tetanus immune globulin ({why})."
        details.append(TIG_DOSE)
    elif cell.vaccine is not None:
        text += " Tetanus immune globulin is not indicated."
    source = ACIP_TETANUS
    recommendation = Recommendation(
        key="tetanus",
        category=RecommendationCategory.tetanus,
        text=text,
        details=details,
        inputs=facts,
        source=source,
        urgent=tig,
    )
    return [recommendation], missing
