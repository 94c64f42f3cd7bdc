"""The Rule of Nines: a standalone estimate, and the comparison figure of a Lund-Browder chart.

Adult: head & neck 9, each arm 9, anterior trunk 18, posterior trunk 18 (buttocks included),
each leg 18, perineum/genitalia 1. Child (below CHILD_NINES_MAX_AGE): head & neck 18, each leg
14, genitalia counted with the anterior trunk.
"""

from __future__ import annotations

import enum
from collections import defaultdict
from collections.abc import Callable

from processing.clinical.checks import check_age, check_fraction, member
from schemas.burn_chart import BurnChart, BurnDepth
from schemas.burn_chart import LundBrowderRegion as R
from schemas.errors import InvalidInput


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
    variant = member(NinesVariant, variant, "Rule-of-Nines variant")
    values = NINES_VALUES[variant]
    total = 0.0
    for group, fraction in group_fractions.items():
        if group not in values:
            raise InvalidInput(
                f"'{group}' is not a group of the {variant.value} Rule of Nines (groups: {', '.join(values)})"
            )
        total += values[group] * check_fraction(fraction, group)
    return round(total, 2)


def nines_from_chart(chart: BurnChart, region_percent: Callable[[R], float], variant: NinesVariant) -> float:
    """Rule-of-Nines %TBSA of a chart: each group's burned share (weighted by the Lund-Browder
    region percentages for the patient's age) times its nines value. Superficial burns excluded."""
    group_total: dict[str, float] = defaultdict(float)
    for region in R:
        group_total[nines_group(region, variant)] += region_percent(region)
    group_burned: dict[str, float] = defaultdict(float)
    for entry in chart.entries:
        if BurnDepth(entry.depth) is BurnDepth.superficial:
            continue
        group_burned[nines_group(entry.region, variant)] += region_percent(entry.region) * entry.fraction
    values = NINES_VALUES[variant]
    return sum(values[g] * burned / group_total[g] for g, burned in group_burned.items())
