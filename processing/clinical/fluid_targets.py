"""Child maintenance fluid (Holliday-Segar) and the hourly urine output target (ABLS 2018).

Both are for children under 30 kg (children.small_child): a 28 kg adult gets the adult
urine target and no maintenance fluid.
"""

from __future__ import annotations

from processing.clinical.checks import check_age, check_weight, member
from processing.clinical.children import small_child
from schemas.clinical_results import MaintenanceFluid, UrineOutputTarget
from schemas.config import ClinicalConfig
from schemas.record_parts import MechanismType

HIGH_VOLTAGE = frozenset({MechanismType.electrical_high_voltage, MechanismType.lightning})

MAINTENANCE_RULE = (
    "Holliday-Segar: 4 mL/kg/h for the first 10 kg + 2 mL/kg/h for the next 10 kg + 1 mL/kg/h "
    "above 20 kg (per day: 100/50/20 mL/kg); give as a dextrose-containing fluid"
)


def maintenance_fluid(weight_kg: float) -> MaintenanceFluid:
    """Hourly (4-2-1) and daily (100-50-20) maintenance fluid for a child of this weight."""
    weight = check_weight(weight_kg)
    first, second, rest = min(weight, 10.0), min(max(weight - 10.0, 0.0), 10.0), max(weight - 20.0, 0.0)
    per_h = 4 * first + 2 * second + 1 * rest
    per_day = 100 * first + 50 * second + 20 * rest
    return MaintenanceFluid(ml_per_h=round(per_h, 1), ml_per_day=round(per_day, 1), rule=MAINTENANCE_RULE)


def urine_output_target(
    weight_kg: float, mechanism: MechanismType | None, config: ClinicalConfig, *, age_years: float | None
) -> UrineOutputTarget:
    """Hourly urine output to titrate to (ABLS 2018); the child target for children under 30 kg."""
    weight = check_weight(weight_kg)
    age = None if age_years is None else check_age(age_years)
    if mechanism is not None and member(MechanismType, mechanism, "mechanism") in HIGH_VOLTAGE:
        low, high = 1.0, 1.5
        basis = (
            "ABLS: high-voltage electrical or lightning injury, 1.0-1.5 mL/kg/h "
            "(75-100 mL/h in adults) until the urine clears of pigment"
        )
    elif small_child(age, weight, config):
        low, high = 1.0, 1.5
        basis = f"ABLS: child < {config.child_max_weight_kg:g} kg, 1.0 mL/kg/h (range 1.0-1.5)"
    else:
        # ABLS gives 0.5 mL/kg/h (30-50 mL/h); sustained output above 1.0 mL/kg/h suggests
        # over-resuscitation (EMSB), so that is the upper end of the range.
        low, high = 0.5, 1.0
        basis = "ABLS: adult 0.5 mL/kg/h (30-50 mL/h in adults); above 1.0 mL/kg/h, reduce the rate"
    return UrineOutputTarget(
        ml_per_kg_per_h_low=low,
        ml_per_kg_per_h_high=high,
        ml_per_h_low=round(low * weight, 1),
        ml_per_h_high=round(high * weight, 1),
        basis=basis,
    )
