"""Burned %TBSA by the Lund-Browder chart, with a Rule-of-Nines figure for comparison.

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
import enum
import math
from collections import defaultdict

from schemas.burn_chart import AgeAdjustment, BurnChart, BurnDepth
from schemas.burn_chart import LundBrowderRegion as R
from schemas.clinical_results import RegionContribution, TbsaResult
from schemas.errors import InvalidInput

COLUMN_AGES: tuple[float, ...] = (0.0, 1.0, 5.0, 10.0, 15.0, 18.0)
COLUMN_LABELS: tuple[str, ...] = ("0 years", "1 year", "5 years", "10 years", "15 years", "adult")
ADULT_AGE = 18.0
MAX_AGE = 130.0

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


class NinesVariant(enum.StrEnum):
    adult = "adult"
    child = "child"


CHILD_NINES_MAX_AGE = 10.0
"""The child Rule of Nines is used below this age; from 10 years the adult rule."""

NINES_VALUES: dict[NinesVariant, dict[str, float]] = {
    NinesVariant.adult: {
        "head_neck": 9,
        "arm_right": 9,
        "arm_left": 9,
        "trunk_anterior": 18,
        "trunk_posterior": 18,
        "leg_right": 18,
        "leg_left": 18,
        "perineum": 1,
    },
    NinesVariant.child: {
        "head_neck": 18,
        "arm_right": 9,
        "arm_left": 9,
        "trunk_anterior": 18,
        "trunk_posterior": 18,
        "leg_right": 14,
        "leg_left": 14,
    },
}

NINES_DESCRIPTIONS: dict[NinesVariant, str] = {
    NinesVariant.adult: (
        "adult Rule of Nines: head & neck 9, each arm 9, anterior trunk 18, posterior trunk 18 "
        "(buttocks included), each leg 18, perineum/genitalia 1"
    ),
    NinesVariant.child: (
        "child Rule of Nines (age < 10): head & neck 18, each arm 9, anterior trunk 18 "
        "(genitalia included), posterior trunk 18 (buttocks included), each leg 14"
    ),
}


def check_age(age_years: float) -> float:
    """The age as a float, or InvalidInput if it is not a possible age in years."""
    if isinstance(age_years, bool) or not isinstance(age_years, (int, float)) or not math.isfinite(age_years):
        raise InvalidInput(f"age {age_years!r} is not a number: enter the patient's age in years (0-130)")
    if not 0 <= age_years <= MAX_AGE:
        raise InvalidInput(f"age {age_years:g} years is impossible: enter the patient's age in years (0-130)")
    return float(age_years)


def _method(method: AgeAdjustment | str) -> AgeAdjustment:
    try:
        return AgeAdjustment(method)
    except ValueError:
        raise InvalidInput(f"unknown age adjustment {method!r}: use 'band' or 'interpolate'") from None


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
    try:
        whole, share = REGION_PARTS[R(region)]
    except ValueError:
        raise InvalidInput(f"unknown Lund-Browder region {region!r}") from None
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


def nines_variant_for_age(age_years: float) -> NinesVariant:
    return NinesVariant.child if check_age(age_years) < CHILD_NINES_MAX_AGE else NinesVariant.adult


def nines_group(region: R, variant: NinesVariant) -> str:
    """The Rule-of-Nines group a Lund-Browder region belongs to."""
    name = R(region).value
    if name.startswith(("head_", "neck_")):
        return "head_neck"
    if name.startswith("buttock_"):
        return "trunk_posterior"
    if name == "genitalia":
        return "perineum" if variant is NinesVariant.adult else "trunk_anterior"
    if name.startswith("trunk_"):
        return name
    side = "right" if "_right_" in name or name.endswith("_right") else "left"
    limb = "arm" if name.startswith(("upper_arm", "lower_arm", "hand")) else "leg"
    return f"{limb}_{side}"


def rule_of_nines(group_fractions: dict[str, float], variant: NinesVariant | str) -> float:
    """%TBSA by the Rule of Nines from the burned fraction (0-1) of each group."""
    try:
        values = NINES_VALUES[NinesVariant(variant)]
    except ValueError:
        raise InvalidInput(f"unknown Rule-of-Nines variant {variant!r}: use 'adult' or 'child'") from None
    total = 0.0
    for group, fraction in group_fractions.items():
        if group not in values:
            raise InvalidInput(
                f"'{group}' is not a group of the {NinesVariant(variant).value} Rule of Nines "
                f"(groups: {', '.join(values)})"
            )
        _check_fraction(fraction, group)
        total += values[group] * fraction
    return round(total, 2)


def palm_estimate(palms: float) -> float:
    """%TBSA from a count of the patient's own palms (with fingers), 0.8 % each."""
    if isinstance(palms, bool) or not isinstance(palms, (int, float)) or not math.isfinite(palms):
        raise InvalidInput(f"palm count {palms!r} is not a number")
    if palms < 0:
        raise InvalidInput(f"palm count {palms:g} is impossible: count the burned area in palms (0 or more)")
    percent = palms * PALM_PERCENT
    if percent > 100:
        raise InvalidInput(f"{palms:g} palms is more than the whole body (100 %TBSA is 125 palms)")
    return round(percent, 2)


def _check_fraction(fraction: float, where: str) -> None:
    if isinstance(fraction, bool) or not isinstance(fraction, (int, float)) or not math.isfinite(fraction):
        raise InvalidInput(f"burned fraction of {where} is not a number")
    if not 0 <= fraction <= 1:
        raise InvalidInput(f"burned fraction {fraction:g} of {where} is impossible: enter a fraction from 0 to 1")


def _validate_entries(chart: BurnChart) -> None:
    seen: set[tuple[R, BurnDepth]] = set()
    region_total: dict[R, float] = defaultdict(float)
    for entry in chart.entries:
        region = R(entry.region)
        _check_fraction(entry.fraction, region.value)
        key = (region, BurnDepth(entry.depth))
        if key in seen:
            raise InvalidInput(
                f"{region.value} is charted twice at depth {key[1].value}: merge the two entries into one"
            )
        seen.add(key)
        region_total[region] += entry.fraction
    for region, total in region_total.items():
        if total > 1 + _FRACTION_TOLERANCE:
            raise InvalidInput(
                f"{region.value} is charted as {total:.2f} of its area burned across depths: "
                "the fractions of one region must add up to at most 1"
            )


def _nines_from_chart(chart: BurnChart, age: float, method: AgeAdjustment, variant: NinesVariant) -> float:
    """Rule-of-Nines %TBSA: each group's LB-weighted burned share times its nines value."""
    group_total: dict[str, float] = defaultdict(float)
    for region in R:
        group_total[nines_group(region, variant)] += region_percent(region, age, method)
    group_burned: dict[str, float] = defaultdict(float)
    for entry in chart.entries:
        if BurnDepth(entry.depth) is BurnDepth.superficial:
            continue
        group = nines_group(entry.region, variant)
        group_burned[group] += region_percent(entry.region, age, method) * entry.fraction
    values = NINES_VALUES[variant]
    return sum(values[g] * burned / group_total[g] for g, burned in group_burned.items())


def compute_tbsa(chart: BurnChart, age_years: float) -> TbsaResult:
    """Burned %TBSA (partial + full thickness) of a chart for a patient of this age."""
    age = check_age(age_years)
    method = _method(chart.age_adjustment)
    _validate_entries(chart)
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
        age_adjustment=column_description(age, method),
        rule_of_nines_percent=round(_nines_from_chart(chart, age, method, variant), 2),
        rule_of_nines_variant=NINES_DESCRIPTIONS[variant],
        contributions=contributions,
    )
