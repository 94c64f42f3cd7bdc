"""First-24-hour burn resuscitation plan (Parkland / ABLS 2018), child maintenance, urine targets.

V = multiplier x weight_kg x %TBSA mL of crystalloid over the first 24 h from the time of
injury (not arrival): half in the first 8 h, half in the next 16 h. The rate to run now
subtracts the fluid already given and spreads what is left of the current phase over the
hours left in it. The plan is a starting point: the rate is titrated hourly to urine output.
"""

from __future__ import annotations

import datetime as dt
import math
from typing import NamedTuple

from processing.clinical.bsa import check_weight
from processing.clinical.lund_browder import check_age
from schemas.base import utcnow
from schemas.clinical_results import FluidPhase, FluidPlan, MaintenanceFluid, UrineOutputTarget
from schemas.config import ClinicalConfig
from schemas.errors import InvalidInput
from schemas.record_parts import FluidFormula, FluidGiven, MechanismType

FIRST_PHASE_H = 8.0
FORMULA_PERIOD_H = 24.0
MAX_CUSTOM_ML = 8.0
HIGH_VOLTAGE = frozenset({MechanismType.electrical_high_voltage, MechanismType.lightning})

TITRATE_WARNING = (
    "This plan is a starting point: titrate the rate hourly to urine output; do not run the formula figure unchanged."
)
MAINTENANCE_RULE = (
    "Holliday-Segar: 4 mL/kg/h for the first 10 kg + 2 mL/kg/h for the next 10 kg + 1 mL/kg/h "
    "above 20 kg (per day: 100/50/20 mL/kg); give as a dextrose-containing fluid"
)


def is_child(age_years: float | None, weight_kg: float | None, config: ClinicalConfig) -> bool | None:
    """Child by the ABA/ABLS rule (age <= 14 or weight < 30 kg by default); None if unknowable."""
    if age_years is not None and age_years <= config.child_max_age_years:
        return True
    if weight_kg is not None and weight_kg < config.child_max_weight_kg:
        return True
    if age_years is not None:
        return False
    return None  # age unknown and weight unknown or above the limit: could still be a child


def maintenance_fluid(weight_kg: float) -> MaintenanceFluid:
    """Hourly (4-2-1) and daily (100-50-20) maintenance fluid for a child of this weight."""
    weight = check_weight(weight_kg)
    first, second, rest = min(weight, 10.0), min(max(weight - 10.0, 0.0), 10.0), max(weight - 20.0, 0.0)
    per_h = 4 * first + 2 * second + 1 * rest
    per_day = 100 * first + 50 * second + 20 * rest
    return MaintenanceFluid(ml_per_h=round(per_h, 1), ml_per_day=round(per_day, 1), rule=MAINTENANCE_RULE)


def urine_output_target(weight_kg: float, mechanism: MechanismType | None, config: ClinicalConfig) -> UrineOutputTarget:
    """Hourly urine output to titrate to (ABLS 2018)."""
    weight = check_weight(weight_kg)
    if mechanism is not None and MechanismType(mechanism) in HIGH_VOLTAGE:
        low, high = 1.0, 1.5
        basis = (
            "ABLS: high-voltage electrical or lightning injury, 1.0-1.5 mL/kg/h "
            "(75-100 mL/h in adults) until the urine clears of pigment"
        )
    elif weight <= config.child_max_weight_kg:
        low, high = 1.0, 1.5
        basis = f"ABLS: child <= {config.child_max_weight_kg:g} kg, 1.0 mL/kg/h (range 1.0-1.5)"
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


def _multiplier(
    formula: FluidFormula, custom: float | None, mechanism: MechanismType | None, child: bool
) -> tuple[float, str]:
    if formula is FluidFormula.parkland:
        return 4.0, "Parkland 4 mL/kg/%TBSA"
    if formula is FluidFormula.custom:
        if custom is None:
            raise InvalidInput("custom fluid formula chosen but no mL/kg/%TBSA given: enter it (up to 8)")
        if isinstance(custom, bool) or not isinstance(custom, (int, float)) or not 0 < custom <= MAX_CUSTOM_ML:
            raise InvalidInput(f"custom formula {custom!r} mL/kg/%TBSA is impossible: enter a value above 0, up to 8")
        return float(custom), f"custom formula: {custom:g} mL/kg/%TBSA chosen by the clinician"
    if mechanism in HIGH_VOLTAGE:
        what = "lightning" if mechanism is MechanismType.lightning else "high-voltage electrical"
        return 4.0, f"ABLS 2018: 4 mL/kg/%TBSA, {what} injury"
    if child:
        return 3.0, "ABLS 2018: 3 mL/kg/%TBSA, child (<= 14 years or < 30 kg)"
    if mechanism is None:
        return 2.0, "ABLS 2018: 2 mL/kg/%TBSA, adult burn (mechanism not recorded)"
    return 2.0, "ABLS 2018: 2 mL/kg/%TBSA, adult thermal burn"


def _check_aware(value: dt.datetime, what: str) -> dt.datetime:
    if not isinstance(value, dt.datetime):
        raise InvalidInput(f"{what} {value!r} is not a date and time")
    if value.tzinfo is None or value.utcoffset() is None:
        raise InvalidInput(f"{what} {value.isoformat()} has no UTC offset: record it with its time zone")
    return value


def _hours_since_injury(time_of_injury: dt.datetime, as_of: dt.datetime, skew_s: float) -> float:
    """Hours from injury to as_of; InvalidInput if the injury lies beyond the clock tolerance."""
    _check_aware(time_of_injury, "time of injury")
    _check_aware(as_of, "assessment time")
    if time_of_injury > utcnow() + dt.timedelta(seconds=skew_s):
        raise InvalidInput(
            f"time of injury {time_of_injury.isoformat()} is in the future: check the time of injury "
            "and the device clock"
        )
    seconds = (as_of - time_of_injury).total_seconds()
    if seconds < -skew_s:
        raise InvalidInput(
            f"time of injury {time_of_injury.isoformat()} is after the assessment time "
            f"{as_of.isoformat()}: check the time of injury and the device clock"
        )
    # An injury up to clock_skew_s after as_of is clock drift between devices: count it as 0 h.
    return max(seconds, 0.0) / 3600.0


def _fluid_given_ml(fluid_given: list[FluidGiven], as_of: dt.datetime) -> tuple[float, int]:
    """Total volume given up to as_of, and how many entries lie after it."""
    total, later = 0.0, 0
    for item in fluid_given:
        volume = item.volume_ml
        if isinstance(volume, bool) or not isinstance(volume, (int, float)) or not math.isfinite(volume):
            raise InvalidInput(f"fluid volume {volume!r} is not a number: enter the volume given in mL")
        if volume < 0:
            raise InvalidInput(f"fluid volume {volume:g} mL is impossible: enter the volume given in mL (0 or more)")
        if _check_aware(item.given_at, "time fluid was given") <= as_of:
            total += volume
        else:
            later += 1
    return total, later


def _check_tbsa(tbsa_percent: float) -> float:
    if isinstance(tbsa_percent, bool) or not isinstance(tbsa_percent, (int, float)) or not math.isfinite(tbsa_percent):
        raise InvalidInput(f"burn size {tbsa_percent!r} is not a number: enter %TBSA (0-100)")
    if not 0 <= tbsa_percent <= 100:
        raise InvalidInput(f"burn size {tbsa_percent:g} %TBSA is impossible: enter %TBSA from 0 to 100")
    return float(tbsa_percent)


def _ml(value: float) -> str:
    return f"{value:,.1f} mL"


def fluid_plan(
    *,
    weight_kg: float,
    tbsa_percent: float,
    age_years: float,
    mechanism: MechanismType | None,
    time_of_injury: dt.datetime,
    as_of: dt.datetime,
    fluid_given: list[FluidGiven],
    formula: FluidFormula,
    custom_ml_per_kg_per_percent: float | None,
    config: ClinicalConfig,
    clock_skew_s: float = 300,
) -> FluidPlan:
    """The first-24-hour crystalloid plan as of `as_of`, clock running from the injury."""
    weight = check_weight(weight_kg)
    tbsa = _check_tbsa(tbsa_percent)
    age = check_age(age_years)
    if isinstance(clock_skew_s, bool) or not isinstance(clock_skew_s, (int, float)) or not clock_skew_s >= 0:
        raise InvalidInput(f"clock skew tolerance {clock_skew_s!r} s is impossible: use 0 or more seconds")
    mechanism = None if mechanism is None else _enum(MechanismType, mechanism, "mechanism")
    formula = _enum(FluidFormula, formula, "fluid formula")
    hours = _hours_since_injury(time_of_injury, as_of, clock_skew_s)
    given, later = _fluid_given_ml(fluid_given, as_of)

    child = bool(is_child(age, weight, config))
    mult, basis = _multiplier(formula, custom_ml_per_kg_per_percent, mechanism, child)
    total = mult * weight * tbsa
    half = total / 2
    threshold = config.formal_resuscitation_child_percent if child else config.formal_resuscitation_adult_percent
    formal = tbsa >= threshold
    maintenance = maintenance_fluid(weight) if child else None
    urine = urine_output_target(weight, mechanism, config)

    phase = _phase(hours, total, given)
    warnings = [TITRATE_WARNING, *phase.warnings]
    warnings += _context_warnings(formula, mechanism, later, as_of)

    statement = _statement(formal, threshold, phase.text, maintenance, urine)
    return FluidPlan(
        formula=formula,
        ml_per_kg_per_percent=mult,
        multiplier_basis=basis,
        weight_kg=weight,
        tbsa_percent=round(tbsa, 2),
        total_24h_ml=round(total, 1),
        first_8h_ml=round(half, 1),
        next_16h_ml=round(half, 1),
        nominal_rate_first_8h_ml_per_h=round(half / 8, 1),
        nominal_rate_next_16h_ml_per_h=round(half / 16, 1),
        time_of_injury=time_of_injury,
        as_of=as_of,
        hours_since_injury=round(hours, 2),
        fluid_given_ml=round(given, 1),
        phase=phase.phase,
        remaining_in_phase_ml=round(phase.remaining, 1),
        hours_left_in_phase=round(phase.hours_left, 2),
        rate_now_ml_per_h=round(phase.rate, 1),
        maintenance=maintenance,
        urine_output_target=urine,
        formal_resuscitation_indicated=formal,
        formal_resuscitation_threshold_percent=threshold,
        statement=statement,
        warnings=warnings,
    )


class _Phase(NamedTuple):
    phase: FluidPhase
    hours_left: float
    remaining: float
    rate: float
    text: str
    warnings: list[str]


def _phase(hours: float, total: float, given: float) -> _Phase:
    """Where the clock stands, what is left of the current phase, and the rate to run now."""
    half = total / 2
    warnings = []
    if hours < FIRST_PHASE_H:
        phase, target, hours_left = FluidPhase.first_8h, half, FIRST_PHASE_H - hours
        remaining = max(0.0, half - given)
        rate = remaining / hours_left
        text = (
            f"First 8 h from injury ({hours:.1f} h elapsed): run {rate:,.1f} mL/h for the next "
            f"{hours_left:.1f} h ({_ml(remaining)} left of {_ml(half)}), then reassess at 8 h."
        )
    elif hours < FORMULA_PERIOD_H:
        phase, target, hours_left = FluidPhase.next_16h, total, FORMULA_PERIOD_H - hours
        remaining = max(0.0, total - given)
        rate = remaining / hours_left
        text = (
            f"Hours 8-24 from injury ({hours:.1f} h elapsed): run {rate:,.1f} mL/h for the remaining "
            f"{hours_left:.1f} h ({_ml(remaining)} left of the 24-hour {_ml(total)})."
        )
        if given < half:
            warnings.append(
                f"Only {_ml(given)} given, less than the first-8-hour volume of {_ml(half)}: "
                "do not bolus the shortfall; titrate to urine output."
            )
    else:
        phase, target, hours_left, remaining, rate = FluidPhase.complete, total, 0.0, 0.0, 0.0
        text = (
            f"The 24-hour formula period is over ({hours:.1f} h since injury): no formula rate; "
            "set fluids by urine output and clinical review."
        )
    if given > target:
        label = "first-8-hour" if phase is FluidPhase.first_8h else "24-hour"
        warnings.append(
            f"Fluid given ({_ml(given)}) exceeds the {label} volume ({_ml(target)}): risk of "
            "over-resuscitation (fluid creep); reduce the rate if urine output is above target."
        )
    return _Phase(phase, hours_left, remaining, rate, text, warnings)


def _statement(
    formal: bool, threshold: float, phase_text: str, maintenance: MaintenanceFluid | None, urine: UrineOutputTarget
) -> str:
    sentences = []
    if not formal:
        sentences.append(
            f"Burn below {threshold:g} %TBSA: formal resuscitation is not usually required; "
            "oral/maintenance fluids and reassess. Formula figures are for reference only:"
        )
    sentences.append(phase_text)
    if maintenance is not None:
        sentences.append(f"Child: add maintenance {maintenance.ml_per_h:,.1f} mL/h (dextrose-containing).")
    sentences.append(
        f"Starting point only: titrate hourly to urine output "
        f"{urine.ml_per_h_low:,.1f}-{urine.ml_per_h_high:,.1f} mL/h."
    )
    return " ".join(sentences)


def _enum(cls, value, what: str):
    try:
        return cls(value)
    except ValueError:
        allowed = ", ".join(member.value for member in cls)
        raise InvalidInput(f"unknown {what} {value!r}: use one of {allowed}") from None


def _context_warnings(
    formula: FluidFormula, mechanism: MechanismType | None, later: int, as_of: dt.datetime
) -> list[str]:
    warnings = []
    if formula is FluidFormula.abls and mechanism is None:
        warnings.append(
            "Mechanism not recorded: ABLS uses 4 mL/kg/%TBSA for high-voltage electrical injury; record the mechanism."
        )
    if mechanism in HIGH_VOLTAGE:
        warnings.append(
            "High-voltage electrical or lightning injury: %TBSA underestimates the deep tissue damage; "
            "watch for pigmented urine."
        )
    if later:
        warnings.append(f"{later} fluid entr{'y' if later == 1 else 'ies'} after {as_of.isoformat()} not counted.")
    return warnings
