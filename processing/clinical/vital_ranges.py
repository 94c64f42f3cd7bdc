"""Vital signs outside the usual range for the patient's age: a warning beside the field, never a refusal (a
burned child is often tachycardic; the clinician confirms the value and it is saved).

Ranges checked (docs/clinical.md):
- heart rate and respiratory rate, children: the PALS awake ranges as tabulated beside the evidence-based
  centiles in Fleming et al., Lancet 2011 (web appendix, Web Box 1), and as PALS course material restates them;
- systolic hypotension: PALS/ATLS, < 60 mmHg in the first month, < 70 to one year, < 70 + 2 x age in years to
  ten years, < 90 mmHg from ten years and in adults (as compared in J Trauma Acute Care Surg 2019;86:448 and
  Hagedoorn et al., Crit Care 2019;23:380);
- temperature: below 35 °C is hypothermia, the threshold the burn-cooling advice already uses;
- adults (18 and over): the values the Royal College of Physicians' NEWS2 chart scores 3 (its "red" single-parameter
  score, which asks for an urgent review): pulse <= 40 or >= 131 /min, breathing <= 8 or >= 25 /min, systolic >= 220
  mmHg; and a temperature of 39.1 °C or more, NEWS2's highest fever band (score 2).
Left out, no checked source: fever in children (NICE's traffic lights are for under-fives' risk of serious illness,
not a plausibility range).
"""

from __future__ import annotations

from processing.clinical.temperature import STOP_COOLING_BELOW_C
from schemas.decision_support import Source
from schemas.record_parts import PrimarySurvey

PALS_RATES = Source(
    guideline="Pediatric Advanced Life Support (PALS) awake ranges, as tabulated in Fleming S et al., Normal ranges "
    "of heart rate and respiratory rate in children from birth to 18 years, Lancet 2011;377:1011-1018",
    year=2011,
    section="Web appendix, Web Box 1: existing reference ranges (PALS row)",
    url="https://pmc.ncbi.nlm.nih.gov/articles/PMC3789232",
)
NEWS2 = Source(
    guideline="Royal College of Physicians. National Early Warning Score (NEWS) 2: standardising the assessment of "
    "acute-illness severity in the NHS. Updated report of a working party. London: RCP, 2017",
    year=2017,
    section="Chart 1: the NEWS scoring system (a score of 3 in one parameter: urgent review)",
    url="https://www.rcp.ac.uk/improving-care/resources/national-early-warning-score-news-2/",
)
PALS_HYPOTENSION = Source(
    guideline="PALS/ATLS definition of systolic hypotension, as compared in J Trauma Acute Care Surg "
    "2019;86(3):448-453 and Hagedoorn NN et al., Crit Care 2019;23:380",
    year=2019,
    section="Low systolic blood pressure by age",
    url="https://pmc.ncbi.nlm.nih.gov/articles/PMC6882047",
)

# (upper age in years, low, high): the first band whose upper age is above the patient's age applies.
HEART_RATE = ((0.25, 85, 205), (2, 100, 190), (10, 60, 140), (18, 60, 100))
RESPIRATORY_RATE = ((1, 30, 60), (4, 24, 40), (6, 22, 34), (13, 18, 30), (18, 12, 16))
ADULT = 18
# NEWS2 Chart 1, the values that score below 3 (adults): outside them the chart scores 3.
ADULT_PULSE = (41, 130)
ADULT_BREATHING = (9, 24)
ADULT_HIGH_SYSTOLIC = 220
ADULT_HIGH_FEVER_C = 39.1


def _band(bands: tuple[tuple[float, int, int], ...], age: float) -> tuple[int, int] | None:
    for upper, low, high in bands:
        if age < upper:
            return low, high
    return None


def low_systolic(age: float) -> float:
    """The systolic pressure below which PALS/ATLS call it hypotension at this age."""
    if age < 1 / 12:
        return 60
    if age < 1:
        return 70
    if age <= 10:
        return 70 + 2 * age
    return 90


def _outside(value: float, low: float, high: float, what: str, unit: str, source: str) -> str | None:
    if low <= value <= high:
        return None
    return f"{value:g} {unit} is outside the usual {what} for this age ({low:g}–{high:g} {unit}, {source}): check it"


def unusual_vitals(survey: PrimarySurvey, age_years: float | None) -> dict[str, str]:
    """Field name (as the form names it) -> the warning, for each vital sign outside its usual range."""
    warnings: dict[str, str] = {}
    hr, rr = survey.circulation.heart_rate_per_min, survey.breathing.respiratory_rate_per_min
    sbp, temp = survey.circulation.systolic_bp_mmhg, survey.exposure.temperature_c
    if age_years is not None and hr is not None and (band := _band(HEART_RATE, age_years)):
        if text := _outside(hr, *band, "heart rate", "/min", "PALS"):
            warnings["circulation.heart_rate_per_min"] = text
    if age_years is not None and rr is not None and (band := _band(RESPIRATORY_RATE, age_years)):
        if text := _outside(rr, *band, "breathing rate", "/min", "PALS"):
            warnings["breathing.respiratory_rate_per_min"] = text
    if age_years is not None and age_years >= ADULT:
        warnings |= _adult_red_scores(hr, rr, sbp, temp)
    if age_years is not None and sbp is not None and sbp < (low := low_systolic(age_years)):
        warnings["circulation.systolic_bp_mmhg"] = (
            f"{sbp} mmHg is below {low:g} mmHg, hypotension at this age (PALS/ATLS): check it and look for shock"
        )
    if temp is not None and temp < STOP_COOLING_BELOW_C:
        warnings["exposure.temperature_c"] = (
            f"{temp:g} °C is below {STOP_COOLING_BELOW_C:g} °C, hypothermia: stop cooling the burn and warm the patient"
        )
    return warnings


def _adult_red_scores(hr: int | None, rr: int | None, sbp: int | None, temp: float | None) -> dict[str, str]:
    warnings: dict[str, str] = {}
    if hr is not None and not ADULT_PULSE[0] <= hr <= ADULT_PULSE[1]:
        warnings["circulation.heart_rate_per_min"] = _red(f"{hr} /min", "a pulse", ADULT_PULSE, "/min")
    if rr is not None and not ADULT_BREATHING[0] <= rr <= ADULT_BREATHING[1]:
        warnings["breathing.respiratory_rate_per_min"] = _red(f"{rr} /min", "a breathing rate", ADULT_BREATHING, "/min")
    if sbp is not None and sbp >= ADULT_HIGH_SYSTOLIC:
        warnings["circulation.systolic_bp_mmhg"] = (
            f"{sbp} mmHg: NEWS2 scores a systolic pressure of {ADULT_HIGH_SYSTOLIC} mmHg or more 3 (urgent review)."
            " Check it; pain and fear raise it"
        )
    if temp is not None and temp >= ADULT_HIGH_FEVER_C:
        warnings["exposure.temperature_c"] = (
            f"{temp:g} °C: {ADULT_HIGH_FEVER_C:g} °C or more is NEWS2's highest fever band. Check it and look for"
            " infection"
        )
    return warnings


def _red(value: str, what: str, kept: tuple[int, int], unit: str) -> str:
    low, high = kept
    return (
        f"{value}: NEWS2 scores {what} of {low - 1} {unit} or less, or {high + 1} {unit} or more, 3 (urgent review)"
        " in an adult. Check it"
    )
