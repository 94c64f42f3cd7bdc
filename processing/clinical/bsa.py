"""Body surface area (Mosteller), and the weight and height checks shared by the calculators."""

from __future__ import annotations

import math

from schemas.clinical_results import BsaResult
from schemas.errors import InvalidInput

MAX_WEIGHT_KG = 400.0
MIN_HEIGHT_CM = 20.0
MAX_HEIGHT_CM = 272.0


def _is_number(value: object) -> bool:
    return not isinstance(value, bool) and isinstance(value, (int, float)) and math.isfinite(value)


def check_weight(weight_kg: float) -> float:
    """The weight as a float, or InvalidInput if no patient can weigh that."""
    if not _is_number(weight_kg):
        raise InvalidInput(f"weight {weight_kg!r} is not a number: enter the patient's weight in kg (0-400)")
    if not 0 < weight_kg <= MAX_WEIGHT_KG:
        raise InvalidInput(f"weight {weight_kg:g} kg is impossible: enter the patient's weight in kg (0-400)")
    return float(weight_kg)


def check_height(height_cm: float) -> float:
    """The height as a float, or InvalidInput if no patient can be that tall."""
    if not _is_number(height_cm):
        raise InvalidInput(f"height {height_cm!r} is not a number: enter the patient's height in cm (20-272)")
    if not MIN_HEIGHT_CM <= height_cm <= MAX_HEIGHT_CM:
        raise InvalidInput(f"height {height_cm:g} cm is impossible: enter the patient's height in cm (20-272)")
    return float(height_cm)


def mosteller(weight_kg: float, height_cm: float) -> BsaResult:
    """Body surface area in m2: sqrt(height_cm x weight_kg / 3600)."""
    weight = check_weight(weight_kg)
    height = check_height(height_cm)
    bsa = math.sqrt(height * weight / 3600.0)
    # Three decimals: a neonate's BSA is about 0.2 m2, where two decimals lose 5 %.
    return BsaResult(bsa_m2=round(bsa, 3), weight_kg=weight, height_cm=height)
