"""Burned %TBSA by the Lund-Browder chart, with a Rule-of-Nines figure (rule_of_nines.py) for comparison.

The published chart gives whole-region percentages for age columns 0, 1, 5, 10, 15 years
and adult. The schema's regions split most of these front/back (or palmar/dorsal,
dorsal/plantar) as on the printed chart; each half gets half the whole-region value.
Buttocks and genitalia are single regions; anterior and posterior trunk are already split.

Age adjustment (AgeAdjustment):
- band: the column of the age band the patient falls in: age < 1 -> '0 years',
  1 <= age < 5 -> '1 year', 5 <= age < 10 -> '5 years', 10 <= age < 15 -> '10 years',
  15 <= age < 18 -> '15 years', age >= 18 -> 'adult'. The chart's last column is headed
  "adult" without an age; we take adulthood from 18 years.
- interpolate: linear between the column ages 0, 1, 5, 10, 15 and 18 (adult), constant
  beyond 18.

Superficial (epidermal) burns are not counted in %TBSA; they are reported separately.
"""

from __future__ import annotations

import bisect
from collections import defaultdict
from typing import get_args

from processing.clinical.checks import Problems, check_age, check_fraction, finite, member
from processing.clinical.rule_of_nines import (
    NINES_DESCRIPTIONS,
    NinesVariant,
    nines_from_chart,
    nines_variant_for_age,
    rule_of_nines,
)
from schemas.burn_chart import AgeAdjustment, BurnChart, BurnDepth, region_name
from schemas.burn_chart import LundBrowderRegion as R
from schemas.clinical_results import AgeSource, RegionContribution, TbsaResult
from schemas.errors import InvalidInput

# Re-exported: callers import the age check and the Rule of Nines from here too.
__all__ = [
    "NinesVariant",
    "check_age",
    "column_description",
    "compute_tbsa",
    "palm_estimate",
    "region_percent",
    "rule_of_nines",
    "validate_chart",
]

COLUMN_AGES: tuple[float, ...] = (0.0, 1.0, 5.0, 10.0, 15.0, 18.0)
COLUMN_LABELS: tuple[str, ...] = ("0 years", "1 year", "5 years", "10 years", "15 years", "adult")
ADULT_AGE = 18.0

# Whole-region % of body surface per column (0, 1, 5, 10, 15, adult). Paired parts
# (buttock, arm, hand, thigh, leg, foot) are "each side".
WHOLE_REGION_PERCENT: dict[str, tuple[float, ...]] = {
    "head": (19, 17, 13, 11, 9, 7),
    "neck": (2,) * 6,
    "trunk_anterior": (13,) * 6,
    "trunk_posterior": (13,) * 6,
    "buttock": (2.5,) * 6,
    "genitalia": (1,) * 6,
    "upper_arm": (4,) * 6,
    "lower_arm": (3,) * 6,
    "hand": (2.5,) * 6,
    "thigh": (5.5, 6.5, 8, 8.5, 9, 9.5),
    "lower_leg": (5, 5, 5.5, 6, 6.5, 7),
    "foot": (3.5,) * 6,
}

HALF = 0.5
# Each chart region -> (whole region, share of it).
REGION_PARTS: dict[R, tuple[str, float]] = {
    R.head_anterior: ("head", HALF),
    R.head_posterior: ("head", HALF),
    R.neck_anterior: ("neck", HALF),
    R.neck_posterior: ("neck", HALF),
    R.trunk_anterior: ("trunk_anterior", 1.0),
    R.trunk_posterior: ("trunk_posterior", 1.0),
    R.buttock_right: ("buttock", 1.0),
    R.buttock_left: ("buttock", 1.0),
    R.genitalia: ("genitalia", 1.0),
    R.upper_arm_right_anterior: ("upper_arm", HALF),
    R.upper_arm_right_posterior: ("upper_arm", HALF),
    R.upper_arm_left_anterior: ("upper_arm", HALF),
    R.upper_arm_left_posterior: ("upper_arm", HALF),
    R.lower_arm_right_anterior: ("lower_arm", HALF),
    R.lower_arm_right_posterior: ("lower_arm", HALF),
    R.lower_arm_left_anterior: ("lower_arm", HALF),
    R.lower_arm_left_posterior: ("lower_arm", HALF),
    R.hand_right_palmar: ("hand", HALF),
    R.hand_right_dorsal: ("hand", HALF),
    R.hand_left_palmar: ("hand", HALF),
    R.hand_left_dorsal: ("hand", HALF),
    R.thigh_right_anterior: ("thigh", HALF),
    R.thigh_right_posterior: ("thigh", HALF),
    R.thigh_left_anterior: ("thigh", HALF),
    R.thigh_left_posterior: ("thigh", HALF),
    R.lower_leg_right_anterior: ("lower_leg", HALF),
    R.lower_leg_right_posterior: ("lower_leg", HALF),
    R.lower_leg_left_anterior: ("lower_leg", HALF),
    R.lower_leg_left_posterior: ("lower_leg", HALF),
    R.foot_right_dorsal: ("foot", HALF),
    R.foot_right_plantar: ("foot", HALF),
    R.foot_left_dorsal: ("foot", HALF),
    R.foot_left_plantar: ("foot", HALF),
}

PALM_PERCENT = 0.8
"""%TBSA of one of the patient's palms including the fingers (Rossiter et al.: about 0.8 %)."""

# Fractions are recorded per entry; a region's total may exceed 1 only by rounding noise.
_FRACTION_TOLERANCE = 1e-9


def _method(method: AgeAdjustment | str) -> AgeAdjustment:
    return member(AgeAdjustment, method, "age adjustment")


def _band_column(age: float) -> int:
    """Index of the chart column whose band holds this age (bands start at the column ages)."""
    return bisect.bisect_right(COLUMN_AGES, age) - 1


def _whole_percent(whole: str, age: float, method: AgeAdjustment) -> float:
    values = WHOLE_REGION_PERCENT[whole]
    if method is AgeAdjustment.band or age >= ADULT_AGE:
        return float(values[_band_column(age)])
    i = _band_column(age)
    a0, a1 = COLUMN_AGES[i], COLUMN_AGES[i + 1]
    return values[i] + (values[i + 1] - values[i]) * (age - a0) / (a1 - a0)


def region_percent(region: R, age_years: float, method: AgeAdjustment) -> float:
    """The region's share of the whole body surface, in %, for this age (unrounded)."""
    age = check_age(age_years)
    whole, share = REGION_PARTS[member(R, region, "Lund-Browder region")]
    return _whole_percent(whole, age, _method(method)) * share


def column_description(age_years: float, method: AgeAdjustment) -> str:
    """Which chart column(s) were used for this age, and how."""
    age = check_age(age_years)
    i = _band_column(age)
    if _method(method) is AgeAdjustment.band:
        label = COLUMN_LABELS[i]
        if i == 0:
            return f"band: column '{label}' (age < 1)"
        if i == len(COLUMN_AGES) - 1:
            return f"band: column '{label}' (age >= 18)"
        return f"band: column '{label}' ({COLUMN_AGES[i]:g} <= age < {COLUMN_AGES[i + 1]:g})"
    if age >= ADULT_AGE:
        return "interpolated: column 'adult' (age >= 18, constant beyond 18)"
    if age == COLUMN_AGES[i]:
        return f"interpolated: exactly column '{COLUMN_LABELS[i]}'"
    upper = f"'{COLUMN_LABELS[i + 1]}'"
    if i + 1 == len(COLUMN_AGES) - 1:
        upper += " (taken as 18 years)"
    return f"interpolated between columns '{COLUMN_LABELS[i]}' and {upper} (age {age:g})"


def palm_estimate(palms: float) -> float:
    """%TBSA from a count of the patient's own palms (with fingers), 0.8 % each."""
    count = finite(palms, "palm count", 0, 100 / PALM_PERCENT, unit="palms (125 palms are the whole body)")
    return round(count * PALM_PERCENT, 2)


def validate_chart(chart: BurnChart) -> None:
    """Refuse a chart no patient can have; the gateway calls this when a chart is written.

    Each entry's region, depth and fraction (0 to 1) must be valid, a region may appear once
    per depth, and the fractions of one region across depths must add up to at most 1.
    Raises InvalidInput naming every problem, with a FieldProblem per offending field
    ("$.entries[2].fraction").
    """
    problems = Problems()
    problems.check(_method, chart.age_adjustment)
    first_at: dict[tuple[R, BurnDepth], int] = {}
    region_entries: dict[R, list[int]] = defaultdict(list)
    region_total: dict[R, float] = defaultdict(float)
    for i, entry in enumerate(chart.entries):
        at = f"$.entries[{i}]"
        region = problems.check(member, R, entry.region, "Lund-Browder region", field=f"{at}.region")
        depth = problems.check(member, BurnDepth, entry.depth, "burn depth", field=f"{at}.depth")
        where = region_name(region).lower() if region is not None else "the region"
        fraction = problems.check(check_fraction, entry.fraction, where, field=f"{at}.fraction")
        if region is None or depth is None or fraction is None:
            continue
        if (region, depth) in first_at:
            problems.add(
                f"{at}.depth",
                f"{region_name(region)} is charted twice at depth {depth.value} (also $.entries[{first_at[region, depth]}]): "
                "merge the two entries into one",
            )
        first_at.setdefault((region, depth), i)
        region_entries[region].append(i)
        region_total[region] += fraction
    for region, total in region_total.items():
        if total > 1 + _FRACTION_TOLERANCE:
            message = (
                f"{region_name(region)} is charted as {total:.2f} of its area burned across depths: "
                "the fractions of one region must add up to at most 1"
            )
            for i in region_entries[region]:
                problems.add(f"$.entries[{i}].fraction", message)
    problems.raise_if_any("burn chart")


def compute_tbsa(chart: BurnChart, age_years: float, *, age_source: AgeSource) -> TbsaResult:
    """Burned %TBSA (partial + full thickness) of a chart for a patient of this age.

    age_source says where the age came from ("date_of_birth" or "estimate"); it is reported
    with the result, since the chart column depends on the age.
    """
    age = check_age(age_years)
    if age_source not in get_args(AgeSource):
        raise InvalidInput(f"unknown age source {age_source!r}: use 'date_of_birth' or 'estimate'")
    validate_chart(chart)
    method = _method(chart.age_adjustment)
    by_depth: dict[BurnDepth, float] = {depth: 0.0 for depth in BurnDepth}
    contributions = []
    for entry in chart.entries:
        percent = region_percent(entry.region, age, method)
        burned = percent * entry.fraction
        by_depth[BurnDepth(entry.depth)] += burned
        contributions.append(
            RegionContribution(
                region=R(entry.region),
                region_percent=round(percent, 2),
                fraction=entry.fraction,
                depth=BurnDepth(entry.depth),
                tbsa_percent=round(burned, 2),
            )
        )
    partial = by_depth[BurnDepth.superficial_partial] + by_depth[BurnDepth.deep_partial]
    full = by_depth[BurnDepth.full_thickness]
    variant = nines_variant_for_age(age)
    return TbsaResult(
        tbsa_percent=round(partial + full, 2),
        superficial_partial_percent=round(by_depth[BurnDepth.superficial_partial], 2),
        deep_partial_percent=round(by_depth[BurnDepth.deep_partial], 2),
        full_thickness_percent=round(full, 2),
        partial_thickness_percent=round(partial, 2),
        excluded_superficial_percent=round(by_depth[BurnDepth.superficial], 2),
        age_years=round(age, 2),
        age_source=age_source,
        age_adjustment=column_description(age, method),
        rule_of_nines_percent=round(nines_from_chart(chart, lambda r: region_percent(r, age, method), variant), 2),
        rule_of_nines_variant=NINES_DESCRIPTIONS[variant],
        contributions=contributions,
    )
