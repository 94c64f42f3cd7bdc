"""Results of the clinical calculators. Decision support only: every figure says how it was made."""

from __future__ import annotations

import enum
from typing import Literal

from schemas.base import Frozen, Id, Timestamp
from schemas.burn_chart import BurnDepth, LundBrowderRegion
from schemas.record_parts import FluidFormula

DECISION_SUPPORT_NOTICE = "Decision support only: a clinician must confirm every figure and decision."

AgeSource = Literal["date_of_birth", "estimate"]
"""Where a calculator's age came from: the date of birth, or the recorded estimate."""


class RegionContribution(Frozen):
    region: LundBrowderRegion
    region_percent: float
    """The region's share of the whole body for this age, in %."""
    fraction: float
    depth: BurnDepth
    tbsa_percent: float
    """region_percent x fraction."""


class TbsaResult(Frozen):
    """Burned %TBSA by Lund-Browder, with a Rule-of-Nines figure for comparison."""

    tbsa_percent: float
    """Partial plus full thickness; superficial (epidermal) burns are excluded."""
    superficial_partial_percent: float
    deep_partial_percent: float
    full_thickness_percent: float
    partial_thickness_percent: float
    excluded_superficial_percent: float
    age_years: float
    age_source: AgeSource
    """Where age_years came from: "date_of_birth" or "estimate" (the chart column depends on it)."""
    age_adjustment: str
    """Which chart column(s) were used and how, e.g. "band: column 5 years"."""
    rule_of_nines_percent: float
    rule_of_nines_variant: str
    contributions: list[RegionContribution]
    method: str = "Lund-Browder"
    unit: str = "% TBSA"


class BsaResult(Frozen):
    bsa_m2: float
    weight_kg: float
    height_cm: float
    method: str = "Mosteller: sqrt(height_cm x weight_kg / 3600)"


class UrineOutputTarget(Frozen):
    ml_per_kg_per_h_low: float
    ml_per_kg_per_h_high: float
    ml_per_h_low: float
    ml_per_h_high: float
    basis: str


class MaintenanceFluid(Frozen):
    ml_per_h: float
    ml_per_day: float
    rule: str


class FluidPhase(enum.StrEnum):
    first_8h = "first_8h"
    next_16h = "next_16h"
    complete = "complete"


class FluidPlan(Frozen):
    """First-24-hour crystalloid plan. A starting point: titrate hourly to urine output."""

    formula: FluidFormula
    ml_per_kg_per_percent: float
    multiplier_basis: str
    """Why this multiplier (always shown to the clinician)."""
    weight_kg: float
    weight_source: str
    """How the weight was obtained and from which record, e.g. "measured, encounter",
    "estimated, patient record", "not recorded, patient record". Volumes scale with the weight."""
    tbsa_percent: float
    total_24h_ml: float
    first_8h_ml: float
    next_16h_ml: float
    nominal_rate_first_8h_ml_per_h: float
    nominal_rate_next_16h_ml_per_h: float
    time_of_injury: Timestamp
    as_of: Timestamp
    hours_since_injury: float
    fluid_given_ml: float
    phase: FluidPhase
    remaining_in_phase_ml: float
    hours_left_in_phase: float
    rate_now_ml_per_h: float
    """Rate to run from as_of, with fluid already given subtracted and the clock from injury."""
    maintenance: MaintenanceFluid | None
    urine_output_target: UrineOutputTarget
    formal_resuscitation_indicated: bool
    formal_resuscitation_threshold_percent: float
    statement: str
    warnings: list[str]


class ReferralTier(enum.StrEnum):
    immediate = "immediate_consultation_consider_transfer"
    consult = "consultation_recommended"
    refer = "referral_criterion"
    """The older single-tier list: any criterion met means refer."""


class CriterionResult(Frozen):
    code: str
    text: str
    tier: ReferralTier
    met: bool | None
    """None when the record lacks the data to decide."""
    reason: str


class GuidelineResult(Frozen):
    guideline: str
    version: str
    criteria: list[CriterionResult]
    met: list[str]
    """Codes of the criteria met."""
    recommendation: str
    undetermined: list[str]


class ReferralAssessment(Frozen):
    current: GuidelineResult
    older: GuidelineResult
    notice: str = DECISION_SUPPORT_NOTICE


class InputRef(Frozen):
    kind: str
    id: Id
    version: int


class Assessment(Frozen):
    """Server-side calculator output stored with the record versions it was computed from."""

    encounter_id: Id
    computed_at: Timestamp
    as_of: Timestamp
    inputs: list[InputRef]
    age_years: float | None
    weight_kg: float | None
    tbsa: TbsaResult | None
    bsa: BsaResult | None
    fluids: FluidPlan | None
    referral: ReferralAssessment | None
    missing: list[str]
    """What the record lacks for the calculators that did not run."""
    calculator_errors: list[str]
    """Calculators that could not run on the data recorded, and why, e.g. "fluid plan: custom fluid
    formula chosen but ...". The other calculators still ran; correct the data named."""
    provenance: list[str]
    """Where each input came from, e.g. "age 34.2 y from date of birth 1991-04-12 at the time of
    injury", "weight 62 kg measured, from the patient record"."""
    caveats: list[str]
    """Limits of this assessment a clinician should weigh, e.g. "weight was estimated: fluid
    volumes are only as good as the weight"."""
    notice: str = DECISION_SUPPORT_NOTICE
