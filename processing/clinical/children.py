"""Who counts as a child, rule by rule: each guideline draws the line in its own place.

- Age: "<= 14 years" (ABA, ABLS) means up to the 15th birthday, so the age in completed
  years is compared: floor(age) <= child_max_age_years. A 14.5-year-old is a child; a
  patient is no longer one from the day they turn 15.
- Fluid multiplier (ABLS 2018, 3 mL/kg/%TBSA): children by age. Only when the age is
  unknown does a weight below child_max_weight_kg stand in for it (the plan says so).
- Maintenance fluid and the child urine target (ABLS): children weighing < 30 kg
  (child_max_weight_kg), unless the age shows the patient is not a child. A 28 kg adult
  gets neither; nor does a 45 kg 12-year-old.
- Referral (ABA 2022 "pediatrics"): <= 14 years (completed years) or < 30 kg.
"""

from __future__ import annotations

import math

from schemas.config import ClinicalConfig


def child_by_age(age_years: float, config: ClinicalConfig) -> bool:
    """Child by age: completed years at most child_max_age_years (14: up to the 15th birthday)."""
    return math.floor(age_years) <= config.child_max_age_years


def below_child_weight(weight_kg: float, config: ClinicalConfig) -> bool:
    """Weight below child_max_weight_kg (30 kg: 29.9 kg is below, 30.0 kg is not)."""
    return weight_kg < config.child_max_weight_kg


def fluid_child(age_years: float | None, weight_kg: float, config: ClinicalConfig) -> tuple[bool, str]:
    """Child for the ABLS fluid multiplier and formal-resuscitation threshold, and why.

    By age (ABLS: children <= 14 years); with the age unknown, by weight < child_max_weight_kg.
    """
    if age_years is not None:
        if child_by_age(age_years, config):
            return True, f"child (<= {config.child_max_age_years:g} years)"
        return False, f"adult (over {config.child_max_age_years:g} years)"
    if below_child_weight(weight_kg, config):
        return True, (
            f"child: age unknown, taken as a child from the weight "
            f"({weight_kg:g} kg < {config.child_max_weight_kg:g} kg)"
        )
    return False, (
        f"adult: age unknown, taken as an adult from the weight ({weight_kg:g} kg >= {config.child_max_weight_kg:g} kg)"
    )


def small_child(age_years: float | None, weight_kg: float, config: ClinicalConfig) -> bool:
    """Child under 30 kg for maintenance fluid and the child urine target (ABLS).

    Weight below child_max_weight_kg, and not known from the age to be past childhood.
    """
    return below_child_weight(weight_kg, config) and (age_years is None or child_by_age(age_years, config))


def aba_pediatric(age_years: float | None, weight_kg: float | None, config: ClinicalConfig) -> bool | None:
    """ABA referral "pediatrics": <= 14 years (completed years) or < 30 kg; None if unknowable."""
    if age_years is not None and child_by_age(age_years, config):
        return True
    if weight_kg is not None and below_child_weight(weight_kg, config):
        return True
    if age_years is not None:
        return False
    return None  # age unknown and weight unknown or above the limit: could still be a child
