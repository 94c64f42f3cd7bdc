"""Body surface area (Mosteller)."""

from __future__ import annotations

import math

from processing.clinical.checks import check_height, check_weight
from schemas.clinical_results import BsaResult

# Re-exported: the weight and height checks used to live here.
__all__ = ["check_height", "check_weight", "mosteller"]


def mosteller(weight_kg: float, height_cm: float) -> BsaResult:
    """Body surface area in m2: sqrt(height_cm x weight_kg / 3600)."""
    weight = check_weight(weight_kg)
    height = check_height(height_cm)
    bsa = math.sqrt(height * weight / 3600.0)
    # Three decimals: a neonate's BSA is about 0.2 m2, where two decimals lose 5 %.
    return BsaResult(bsa_m2=round(bsa, 3), weight_kg=weight, height_cm=height)
