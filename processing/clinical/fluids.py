"""First-24-hour burn resuscitation plan (Parkland / ABLS 2018); maintenance and urine targets in fluid_targets.py.

V = multiplier x weight_kg x %TBSA mL of crystalloid over the first 24 h from the time of
injury (not arrival): half in the first 8 h, half in the next 16 h. The rate to run now
subtracts the fluid already given and spreads what is left of the current phase over the
hours left in it. The plan is a starting point: the rate is titrated hourly to urine output.

Who counts as a child differs by rule (children.py): the 3 mL multiplier and the formal-
resuscitation threshold go by age (<= 14 years); maintenance fluid and the child urine target
by weight (< 30 kg) unless the age shows the patient is past childhood.

Pure: the plan depends only on its arguments. Injury times in the real future are refused
when they are written (gateway validation); here only injury against as_of is checked.
"""

from __future__ import annotations

import datetime as dt
from typing import NamedTuple

from processing.clinical.checks import Problems, aware, check_age, check_weight, finite, invalid, member
from processing.clinical.children import fluid_child, small_child
from processing.clinical.fluid_targets import HIGH_VOLTAGE, maintenance_fluid, urine_output_target
from schemas.base import iso
from schemas.clinical_results import FluidPhase, FluidPlan, MaintenanceFluid, UrineOutputTarget
from schemas.config import ClinicalConfig
from schemas.errors import InvalidInput
from schemas.record_parts import FluidFormula, FluidGiven, MechanismType, Resuscitation

# Re-exported: maintenance and urine targets live in fluid_targets.py.
__all__ = ["fluid_plan", "maintenance_fluid", "urine_output_target", "validate_resuscitation"]

FIRST_PHASE_H = 8.0
FORMULA_PERIOD_H = 24.0
MAX_CUSTOM_ML = 8.0

TITRATE_WARNING = (
    "This plan is a starting point: titrate the rate hourly to urine output; do not run the formula figure unchanged."
)


def _multiplier(
    formula: FluidFormula, custom: float | None, mechanism: MechanismType | None, child: bool, who: str
) -> tuple[float, str]:
    if formula is FluidFormula.parkland:
        return 4.0, "Parkland 4 mL/kg/%TBSA"
    if formula is FluidFormula.custom:
        return custom, f"custom formula: {custom:g} mL/kg/%TBSA chosen by the clinician"
    if mechanism in HIGH_VOLTAGE:
        what = "lightning" if mechanism is MechanismType.lightning else "high-voltage electrical"
        return 4.0, f"ABLS 2018: 4 mL/kg/%TBSA, {what} injury"
    if child:
        return 3.0, f"ABLS 2018: 3 mL/kg/%TBSA, {who}"
    # Only an unknown age needs saying: "adult (over 14 years)" adds nothing to "adult".
    note = f" ({who})" if who.startswith("adult:") else ""
    if mechanism is None:
        return 2.0, f"ABLS 2018: 2 mL/kg/%TBSA, adult burn (mechanism not recorded){note}"
    return 2.0, f"ABLS 2018: 2 mL/kg/%TBSA, adult thermal burn{note}"


def _resuscitation_problems(formula: object, custom: object, fluid_given: list[FluidGiven]) -> Problems:
    """What is wrong with a formula choice and the fluid given, field by field."""
    problems = Problems()
    formula = problems.check(member, FluidFormula, formula, "fluid formula", field="$.formula")
    field = "$.custom_ml_per_kg_per_percent"
    if formula is FluidFormula.custom and custom is None:
        problems.add(field, f"custom fluid formula chosen but no mL/kg/%TBSA given: enter it (up to {MAX_CUSTOM_ML:g})")
    elif custom is not None:
        problems.check(
            finite, custom, "custom formula", 0, MAX_CUSTOM_ML, lo_open=True, unit="mL/kg/%TBSA", field=field
        )
    for i, item in enumerate(fluid_given):
        at = f"$.fluid_given[{i}]"
        problems.check(finite, item.volume_ml, "fluid volume", 0, unit="mL", field=f"{at}.volume_ml")
        problems.check(aware, item.given_at, "time fluid was given", field=f"{at}.given_at")
    return problems


def validate_resuscitation(r: Resuscitation) -> None:
    """Refuse a resuscitation record that cannot be used; the gateway calls this when it is written.

    A custom formula needs custom_ml_per_kg_per_percent (above 0, up to 8); volumes given are
    numbers of 0 mL or more, given at times with a UTC offset. Raises InvalidInput naming every
    problem, with a FieldProblem per offending field ("$.fluid_given[1].volume_ml").
    """
    _resuscitation_problems(r.formula, r.custom_ml_per_kg_per_percent, r.fluid_given).raise_if_any("resuscitation")


def _hours_since_injury(time_of_injury: dt.datetime, as_of: dt.datetime, skew_s: float) -> float:
    """Hours from injury to as_of; InvalidInput if the injury lies beyond the clock tolerance after as_of."""
    aware(time_of_injury, "time of injury")
    aware(as_of, "assessment time")
    seconds = (as_of - time_of_injury).total_seconds()
    if seconds < -skew_s:
        raise InvalidInput(
            f"time of injury {iso(time_of_injury)} is after the assessment time "
            f"{iso(as_of)}: check the time of injury and the device clock"
        )
    # An injury up to clock_skew_s after as_of is clock drift between devices: count it as 0 h.
    return max(seconds, 0.0) / 3600.0


def _fluid_given_ml(fluid_given: list[FluidGiven], as_of: dt.datetime) -> tuple[float, int]:
    """Total volume given up to as_of, and how many entries lie after it (entries already checked)."""
    total, later = 0.0, 0
    for item in fluid_given:
        if item.given_at <= as_of:
            total += item.volume_ml
        else:
            later += 1
    return total, later


def _ml(value: float) -> str:
    return f"{value:,.1f} mL"


def fluid_plan(
    *,
    weight_kg: float,
    weight_source: str,
    tbsa_percent: float,
    age_years: float | None,
    mechanism: MechanismType | None,
    time_of_injury: dt.datetime,
    as_of: dt.datetime,
    fluid_given: list[FluidGiven],
    formula: FluidFormula,
    custom_ml_per_kg_per_percent: float | None,
    config: ClinicalConfig,
    clock_skew_s: float,
) -> FluidPlan:
    """The first-24-hour crystalloid plan as of `as_of`, clock running from the injury.

    weight_source says how the weight was obtained, e.g. "measured, encounter" (reported with
    the plan). age_years may be None: the child rules then go by weight, and the plan says so.
    clock_skew_s: how far (s) the injury may lie after as_of and still count as 0 h (clock drift).
    """
    weight = check_weight(weight_kg)
    if not isinstance(weight_source, str) or not weight_source.strip():
        raise invalid(f"weight source {weight_source!r} is not a description: say how the weight was obtained")
    tbsa = finite(tbsa_percent, "burn size", 0, 100, unit="%TBSA")
    age = None if age_years is None else check_age(age_years)
    skew = finite(clock_skew_s, "clock skew tolerance", 0, unit="s")
    mechanism = None if mechanism is None else member(MechanismType, mechanism, "mechanism")
    _resuscitation_problems(formula, custom_ml_per_kg_per_percent, fluid_given).raise_if_any("resuscitation")
    formula = FluidFormula(formula)
    custom = None if custom_ml_per_kg_per_percent is None else float(custom_ml_per_kg_per_percent)
    hours = _hours_since_injury(time_of_injury, as_of, skew)
    given, later = _fluid_given_ml(fluid_given, as_of)

    child, who = fluid_child(age, weight, config)
    mult, basis = _multiplier(formula, custom, mechanism, child, who)
    total = mult * weight * tbsa
    half = total / 2
    threshold = config.formal_resuscitation_child_percent if child else config.formal_resuscitation_adult_percent
    formal = tbsa >= threshold
    maintenance = maintenance_fluid(weight) if small_child(age, weight, config) else None
    urine = urine_output_target(weight, mechanism, config, age_years=age)

    phase = _phase(hours, total, given)
    warnings = [TITRATE_WARNING, *phase.warnings]
    if age is None:
        warnings.append(f"Age not recorded: treated as {who}; record the age (or an estimate).")
    warnings += _context_warnings(formula, mechanism, later, as_of)

    statement = _statement(formal, threshold, phase.text, maintenance, urine)
    return FluidPlan(
        formula=formula,
        ml_per_kg_per_percent=mult,
        multiplier_basis=basis,
        weight_kg=weight,
        weight_source=weight_source,
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
        warnings.append(f"{later} fluid entr{'y' if later == 1 else 'ies'} after {iso(as_of)} not counted.")
    return warnings
