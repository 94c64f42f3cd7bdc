"""Burn-center referral criteria: the facts and criteria both guideline tables share (assess_referral, in
referral.py, judges both).

Two guidelines are judged on the same record, each in its own module:

- referral_aba2022: the current two-tier table, from
  American Burn Association, Guidelines for Burn Patient Referral, 2022
  (immediate consultation with consideration for transfer / consultation recommended).
  The table must be checked against the current published version by the clinical lead.
- referral_aba2006: the older single list (ABA/ACS Guidelines for the Operation of Burn Centers, 2006).

Each criterion is judged from the record alone and says why: met True/False, or None when
the record lacks the data (e.g. no burn chart), so that a missing chart never reads as
"no criterion met". Where the chart is used for critical areas, the anterior head region is
taken to include the face; perineum and major joints come from the chart's special areas.
"""

from __future__ import annotations

from collections.abc import Callable

import msgspec

from processing.clinical.children import aba_pediatric
from schemas.burn_chart import BurnChart, BurnDepth, LundBrowderRegion, SpecialArea, region_name
from schemas.clinical_results import (
    CriterionResult,
    ReferralTier,
    TbsaResult,
)
from schemas.config import ClinicalConfig
from schemas.record_parts import AirwayIntervention, Intake, Mechanism, MechanismType, PrimarySurvey, SecondarySurvey

GUIDELINE = "American Burn Association Burn Center Referral Criteria"

NO_CHART = "no burn chart recorded"
NO_TBSA = "%TBSA not computed: the patient's date of birth or estimated age is needed"
NO_MECHANISM = "no mechanism of injury recorded"
NO_INTAKE = "no intake (history) recorded"
NO_SECONDARY = "no secondary survey recorded"
HIGH_VOLTAGE_V = 1000.0

PARTIAL = frozenset({BurnDepth.superficial_partial, BurnDepth.deep_partial})
DEEP = frozenset({BurnDepth.deep_partial, BurnDepth.full_thickness})
DEEP_PARTIAL = frozenset({BurnDepth.deep_partial})
NOT_SUPERFICIAL = frozenset({BurnDepth.superficial_partial, BurnDepth.deep_partial, BurnDepth.full_thickness})
FULL = frozenset({BurnDepth.full_thickness})

# Chart regions that show a critical area; perineum and major joints only as special areas.
AREA_REGIONS: dict[SpecialArea, frozenset[LundBrowderRegion]] = {
    SpecialArea.face: frozenset({LundBrowderRegion.head_anterior}),
    SpecialArea.hands: frozenset(r for r in LundBrowderRegion if r.value.startswith("hand_")),
    SpecialArea.feet: frozenset(r for r in LundBrowderRegion if r.value.startswith("foot_")),
    SpecialArea.genitalia: frozenset({LundBrowderRegion.genitalia}),
    SpecialArea.perineum: frozenset(),
    SpecialArea.major_joint: frozenset(),
}
# Airway signs of suspected inhalation injury (singed nasal hair alone is only a sign of potential injury).
STRONG_AIRWAY_SIGNS = (
    ("carbonaceous_sputum", "carbonaceous sputum"),
    ("soot_in_mouth_or_nose", "soot in mouth or nose"),
    ("hoarse_voice", "hoarse voice"),
    ("stridor", "stridor"),
    ("oropharyngeal_oedema", "oropharyngeal oedema"),
)

Verdict = tuple[bool | None, str]


class ReferralInputs(msgspec.Struct, frozen=True, kw_only=True):
    """Whatever the record holds; any part may be absent."""

    age_years: float | None = None
    weight_kg: float | None = None
    tbsa: TbsaResult | None = None
    chart: BurnChart | None = None
    mechanism: Mechanism | None = None
    primary: PrimarySurvey | None = None
    secondary: SecondarySurvey | None = None
    intake: Intake | None = None
    config: ClinicalConfig = msgspec.field(default_factory=ClinicalConfig)


# --- facts drawn from the record -------------------------------------------------------


def burned_regions(chart: BurnChart, depths: frozenset[BurnDepth]) -> list[str]:
    return [
        region_name(LundBrowderRegion(e.region)).lower()
        for e in chart.entries
        if e.fraction > 0 and BurnDepth(e.depth) in depths
    ]


def burned_anywhere(chart: BurnChart, depths: frozenset[BurnDepth]) -> list[str]:
    """Chart regions and special areas burned at one of these depths."""
    return burned_regions(chart, depths) + [
        f"{SpecialArea(s.area).value} (special area)" for s in chart.special_areas if BurnDepth(s.depth) in depths
    ]


def _area_hits(chart: BurnChart, area: SpecialArea, depths: frozenset[BurnDepth]) -> list[str]:
    """What shows this critical area burned at one of these depths: chart regions and special areas."""
    hits = [
        f"{region_name(LundBrowderRegion(e.region)).lower()} ({_depth_words(e.depth)})"
        for e in chart.entries
        if e.fraction > 0 and e.region in AREA_REGIONS[area] and BurnDepth(e.depth) in depths
    ]
    hits += [
        f"special area ({_depth_words(s.depth)})"
        for s in chart.special_areas
        if s.area == area and BurnDepth(s.depth) in depths
    ]
    return hits


def _depth_words(depth: BurnDepth | str) -> str:
    return BurnDepth(depth).value.replace("_", " ")


def _critical_areas(chart: BurnChart, depths: frozenset[BurnDepth]) -> list[str]:
    """Descriptions of each critical area burned at one of these depths."""
    found = []
    for area in AREA_REGIONS:
        hits = _area_hits(chart, area, depths)
        if hits:
            from_head = any(hit.startswith(region_name(LundBrowderRegion.head_anterior).lower()) for hit in hits)
            note = " (the anterior head region is taken to include the face)" if from_head else ""
            found.append(f"{area.value}: {' and '.join(hits)}{note}")
    return found


def child_status(inp: ReferralInputs) -> tuple[bool | None, str]:
    """Child by the ABA referral wording (<= 14 years in completed years, or < 30 kg), and what is known."""
    child = aba_pediatric(inp.age_years, inp.weight_kg, inp.config)
    known = [f"age {round(inp.age_years, 1):g} years" if inp.age_years is not None else "age unknown"]
    if inp.weight_kg is not None:
        known.append(f"weight {round(inp.weight_kg, 1):g} kg")
    return child, ", ".join(known)


def _electrical(mechanism: Mechanism) -> str | None:
    """'high' (>= 1000 V or lightning), 'low', or None for a non-electrical mechanism."""
    kind = MechanismType(mechanism.type)
    if kind in (MechanismType.electrical_high_voltage, MechanismType.lightning):
        return "high"
    if kind is MechanismType.electrical_low_voltage:
        high = mechanism.voltage_v is not None and mechanism.voltage_v >= HIGH_VOLTAGE_V
        return "high" if high else "low"
    return None


# --- criteria shared by both lists ------------------------------------------------------


def full_thickness(inp: ReferralInputs) -> Verdict:
    if inp.chart is None:
        return None, NO_CHART
    where = burned_anywhere(inp.chart, FULL)
    if not where:
        return False, "no full-thickness burn charted"
    size = f" {inp.tbsa.full_thickness_percent:.2f} %TBSA" if inp.tbsa is not None else ""
    return True, f"full-thickness burns{size} ({'; '.join(where)})"


def partial_size(inp: ReferralInputs) -> float | Verdict:
    """Partial-thickness %TBSA, or the verdict when it cannot be (or need not be) known."""
    if inp.chart is None:
        return None, NO_CHART
    if not burned_regions(inp.chart, PARTIAL):
        return False, "no partial-thickness burn charted"
    if inp.tbsa is None:
        return None, NO_TBSA
    return inp.tbsa.partial_thickness_percent


def partial_at_least(limit: float, strict: bool) -> Callable[[ReferralInputs], Verdict]:
    def judge(inp: ReferralInputs) -> Verdict:
        size = partial_size(inp)
        if isinstance(size, tuple):
            return size
        met = size > limit if strict else size >= limit
        sign = (">" if met else "<=") if strict else (">=" if met else "<")
        return met, f"partial-thickness burns {size:.2f} %TBSA ({sign} {limit:g})"

    return judge


def critical_areas(depths: frozenset[BurnDepth], depth_words: str) -> Callable[[ReferralInputs], Verdict]:
    def judge(inp: ReferralInputs) -> Verdict:
        if inp.chart is None:
            return None, NO_CHART
        found = _critical_areas(inp.chart, depths)
        if not found:
            return (
                False,
                f"no {depth_words} burn of the face, hands, feet, genitalia, perineum or a major joint charted",
            )
        return True, "; ".join(found)

    return judge


def strong_airway_signs(primary: PrimarySurvey) -> list[str]:
    """Signs of suspected inhalation injury recorded in the primary survey."""
    signs = [label for attr, label in STRONG_AIRWAY_SIGNS if getattr(primary.airway, attr)]
    cohb = primary.breathing.carboxyhaemoglobin_percent
    if cohb is not None and cohb > 10:
        signs.append(f"carboxyhaemoglobin {cohb:g} % (> 10)")
    if primary.airway.intervention in (AirwayIntervention.intubated, AirwayIntervention.surgical_airway):
        signs.append(f"airway: {AirwayIntervention(primary.airway.intervention).value.replace('_', ' ')}")
    return signs


def facial_burns(inp: ReferralInputs) -> bool:
    """Facial burns of any depth, from the airway assessment or the chart."""
    return (inp.primary is not None and inp.primary.airway.facial_burns) or (
        inp.chart is not None and bool(_area_hits(inp.chart, SpecialArea.face, frozenset(BurnDepth)))
    )


def chemical(inp: ReferralInputs) -> Verdict:
    if inp.mechanism is None:
        return None, NO_MECHANISM
    kind = MechanismType(inp.mechanism.type)
    agent = f" ({inp.mechanism.agent})" if inp.mechanism.agent else ""
    return kind is MechanismType.chemical, f"mechanism: {kind.value}{agent}"


def electrical(kinds: frozenset[str]) -> Callable[[ReferralInputs], Verdict]:
    def judge(inp: ReferralInputs) -> Verdict:
        if inp.mechanism is None:
            return None, NO_MECHANISM
        volts = f", {inp.mechanism.voltage_v:g} V" if inp.mechanism.voltage_v is not None else ""
        reason = f"mechanism: {MechanismType(inp.mechanism.type).value}{volts}"
        return _electrical(inp.mechanism) in kinds, reason

    return judge


def comorbidities(inp: ReferralInputs) -> Verdict:
    if inp.intake is None:
        return None, NO_INTAKE
    found = inp.intake.significant_comorbidities
    if not found:
        return False, "no significant comorbidity recorded"
    return True, f"significant comorbidities: {', '.join(found)}"


def major_injuries(inp: ReferralInputs) -> list[str] | Verdict:
    if inp.secondary is None:
        return None, NO_SECONDARY
    return [i.description for i in inp.secondary.other_injuries if i.major]


def trauma(inp: ReferralInputs) -> Verdict:
    major = major_injuries(inp)
    if isinstance(major, tuple):
        return major
    if not major:
        return False, "no major injury other than the burn recorded"
    return True, f"major other injuries: {'; '.join(major)}"


# --- judging a list ------------------------------------------------------------------------

Rule = tuple[str, str, ReferralTier, Callable[[ReferralInputs], Verdict]]
IMMEDIATE, CONSULT, REFER = ReferralTier.immediate, ReferralTier.consult, ReferralTier.refer


def judge_rules(rules: tuple[Rule, ...], inp: ReferralInputs) -> list[CriterionResult]:
    results = []
    for code, text, tier, judge in rules:
        met, reason = judge(inp)
        results.append(CriterionResult(code=code, text=text, tier=tier, met=met, reason=reason))
    return results


def unassessed(recommendation: str, undetermined: list[CriterionResult]) -> str:
    """The recommendation, then the criteria the record cannot decide, by their text (the codes are in
    GuidelineResult.undetermined); readers that show those texts elsewhere cut at NOT_ASSESSABLE."""
    if not undetermined:
        return recommendation
    return f"{recommendation}{NOT_ASSESSABLE}{'; '.join(c.text for c in undetermined)}"


NOT_ASSESSABLE = "; not assessable from the record: "
NOTHING_JUDGED = "Not assessed yet: the record lacks what the criteria need"
