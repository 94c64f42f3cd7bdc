"""Burn-center referral criteria: the ABA 2022 two-tier guideline and the older single list.

Each criterion is judged from the record alone and says why: met True/False, or None when
the record lacks the data (e.g. no burn chart), so that a missing chart never reads as
"no criterion met". Where the chart is used for critical areas, the anterior head region is
taken to include the face; perineum and major joints come from the chart's special areas.
"""

from __future__ import annotations

from collections.abc import Callable

import msgspec

from processing.clinical.fluids import is_child
from schemas.burn_chart import BurnChart, BurnDepth, LundBrowderRegion, SpecialArea
from schemas.clinical_results import (
    CriterionResult,
    GuidelineResult,
    ReferralAssessment,
    ReferralTier,
    TbsaResult,
)
from schemas.config import ClinicalConfig
from schemas.record_parts import AirwayIntervention, Intake, Mechanism, MechanismType, PrimarySurvey, SecondarySurvey

GUIDELINE = "American Burn Association Burn Center Referral Criteria"
CURRENT_VERSION = "ABA 2022 (two-tier)"
OLDER_VERSION = "ABA/ACS Guidelines for the Operation of Burn Centers (2006) — single list"

NO_CHART = "no burn chart recorded"
NO_TBSA = "%TBSA not computed: the patient's date of birth or estimated age is needed"
NO_MECHANISM = "no mechanism of injury recorded"
NO_INTAKE = "no intake (history) recorded"
NO_SECONDARY = "no secondary survey recorded"
HIGH_VOLTAGE_V = 1000.0

PARTIAL = frozenset({BurnDepth.superficial_partial, BurnDepth.deep_partial})
DEEP = frozenset({BurnDepth.deep_partial, BurnDepth.full_thickness})
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
AIRWAY_SIGNS = (
    ("singed_nasal_hair", "singed nasal hair"),
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


def _burned(chart: BurnChart, depths: frozenset[BurnDepth]) -> list[str]:
    return [LundBrowderRegion(e.region).value for e in chart.entries if e.fraction > 0 and BurnDepth(e.depth) in depths]


def _area_hits(chart: BurnChart, area: SpecialArea, depths: frozenset[BurnDepth]) -> list[str]:
    """What shows this critical area burned at one of these depths: chart regions and special areas."""
    hits = [
        f"{LundBrowderRegion(e.region).value} {BurnDepth(e.depth).value}"
        for e in chart.entries
        if e.fraction > 0 and e.region in AREA_REGIONS[area] and BurnDepth(e.depth) in depths
    ]
    hits += [
        f"special area {BurnDepth(s.depth).value}"
        for s in chart.special_areas
        if s.area == area and BurnDepth(s.depth) in depths
    ]
    return hits


def _critical_areas(chart: BurnChart, depths: frozenset[BurnDepth]) -> list[str]:
    """Descriptions of each critical area burned at one of these depths."""
    found = []
    for area in AREA_REGIONS:
        hits = _area_hits(chart, area, depths)
        if hits:
            from_head = any(hit.startswith(LundBrowderRegion.head_anterior.value) for hit in hits)
            note = " (the anterior head region is taken to include the face)" if from_head else ""
            found.append(f"{area.value}: {', '.join(hits)}{note}")
    return found


def _child(inp: ReferralInputs) -> tuple[bool | None, str]:
    child = is_child(inp.age_years, inp.weight_kg, inp.config)
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


def _social_needs(intake: Intake) -> list[str]:
    social = intake.social
    flags = [
        (social.safeguarding_concern, "safeguarding concern (possible non-accidental injury)"),
        (social.substance_use, "substance use"),
        (social.needs_rehabilitation_support, "special social, emotional or rehabilitative needs"),
    ]
    return [label for flag, label in flags if flag]


# --- criteria shared by both lists ------------------------------------------------------


def full_thickness(inp: ReferralInputs) -> Verdict:
    if inp.chart is None:
        return None, NO_CHART
    where = _burned(inp.chart, FULL) + [
        f"{SpecialArea(s.area).value} (special area)"
        for s in inp.chart.special_areas
        if BurnDepth(s.depth) is BurnDepth.full_thickness
    ]
    if not where:
        return False, "no full-thickness burn charted"
    size = f" {inp.tbsa.full_thickness_percent:.2f} %TBSA" if inp.tbsa is not None else ""
    return True, f"full-thickness burns{size} ({', '.join(where)})"


def _partial_size(inp: ReferralInputs) -> float | Verdict:
    """Partial-thickness %TBSA, or the verdict when it cannot be (or need not be) known."""
    if inp.chart is None:
        return None, NO_CHART
    if not _burned(inp.chart, PARTIAL):
        return False, "no partial-thickness burn charted"
    if inp.tbsa is None:
        return None, NO_TBSA
    return inp.tbsa.partial_thickness_percent


def partial_at_least(limit: float, strict: bool) -> Callable[[ReferralInputs], Verdict]:
    def judge(inp: ReferralInputs) -> Verdict:
        size = _partial_size(inp)
        if isinstance(size, tuple):
            return size
        met = size > limit if strict else size >= limit
        sign = (">" if met else "<=") if strict else (">=" if met else "<")
        return met, f"partial-thickness burns {size:.2f} %TBSA ({sign} {limit:g})"

    return judge


def partial_below_10(inp: ReferralInputs) -> Verdict:
    size = _partial_size(inp)
    if isinstance(size, tuple):
        return size
    if size >= 10:
        return False, f"partial-thickness burns {size:.2f} %TBSA (>= 10: immediate tier)"
    return size > 0, f"partial-thickness burns {size:.2f} %TBSA (< 10)"


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


def inhalation(inp: ReferralInputs) -> Verdict:
    signs = []
    primary = inp.primary
    if primary is not None:
        signs += [label for attr, label in AIRWAY_SIGNS if getattr(primary.airway, attr)]
        cohb = primary.breathing.carboxyhaemoglobin_percent
        if cohb is not None and cohb > 10:
            signs.append(f"carboxyhaemoglobin {cohb:g} % (> 10)")
        if primary.airway.intervention in (AirwayIntervention.intubated, AirwayIntervention.surgical_airway):
            signs.append(f"airway: {AirwayIntervention(primary.airway.intervention).value.replace('_', ' ')}")
    # Any depth: a superficial facial flash burn in an enclosed space is still a warning sign.
    facial = (primary is not None and primary.airway.facial_burns) or (
        inp.chart is not None and bool(_area_hits(inp.chart, SpecialArea.face, frozenset(BurnDepth)))
    )
    if facial and inp.mechanism is not None and inp.mechanism.enclosed_space:
        signs.append("facial burns with an enclosed-space injury")
    if signs:
        return True, "; ".join(signs)
    if primary is None:
        return None, "no primary survey recorded (airway signs of inhalation)"
    return False, "no sign of inhalation injury recorded"


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


def social_needs(inp: ReferralInputs) -> Verdict:
    if inp.intake is None:
        return None, NO_INTAKE
    needs = _social_needs(inp.intake)
    return (
        (True, "; ".join(needs)) if needs else (False, "no special social, emotional or rehabilitative need recorded")
    )


def _major_injuries(inp: ReferralInputs) -> list[str] | Verdict:
    if inp.secondary is None:
        return None, NO_SECONDARY
    return [i.description for i in inp.secondary.other_injuries if i.major]


def trauma(inp: ReferralInputs) -> Verdict:
    major = _major_injuries(inp)
    if isinstance(major, tuple):
        return major
    if not major:
        return False, "no major injury other than the burn recorded"
    return True, f"major other injuries: {'; '.join(major)}"


# --- criteria of one list only ----------------------------------------------------------


def pediatric_safeguarding(inp: ReferralInputs) -> Verdict:
    child, who = _child(inp)
    if child is False:
        return False, f"not a child ({who})"
    if inp.intake is None:
        return None, NO_INTAKE
    if not inp.intake.social.safeguarding_concern:
        return False, "no safeguarding concern recorded"
    if child is None:
        return None, f"safeguarding concern recorded, but whether the patient is a child is unknown ({who})"
    return True, f"child ({who}) with a safeguarding concern (possible non-accidental trauma)"


def pediatric(inp: ReferralInputs) -> Verdict:
    child, who = _child(inp)
    if child is None:
        return None, f"the patient's age or weight is needed ({who})"
    if not child:
        return False, f"not a child ({who})"
    if inp.chart is not None:
        burned = _burned(inp.chart, frozenset(BurnDepth))
        burned = burned or [SpecialArea(s.area).value for s in inp.chart.special_areas]
        if burned:
            return True, f"child ({who}) with burns charted ({', '.join(burned)})"
        if inp.mechanism is None:
            return False, f"child ({who}), but no burn charted"
    if inp.mechanism is not None:
        return True, f"child ({who}) with a burn injury ({MechanismType(inp.mechanism.type).value})"
    return None, f"child ({who}); {NO_CHART}"


def trauma_greatest_risk(inp: ReferralInputs) -> Verdict:
    major = _major_injuries(inp)
    if isinstance(major, tuple):
        return major
    if not major:
        return False, "no major injury other than the burn recorded"
    injuries = "; ".join(major)
    risk = inp.secondary.burn_poses_greatest_risk
    if risk is None:
        return None, f"major other injuries ({injuries}): record whether the burn or the trauma is the greater risk"
    if not risk:
        return False, (
            f"major other injuries ({injuries}) pose the greater risk: stabilise in a trauma center, "
            "then consider transfer to a burn center"
        )
    return True, f"major other injuries ({injuries}); the burn poses the greatest risk"


def children_facility(inp: ReferralInputs) -> Verdict:
    child, who = _child(inp)
    if child is False:
        return False, f"not a child ({who})"
    facility = (
        "depends on whether this facility has qualified personnel and equipment for burned children, "
        "which the record cannot show: decide locally"
    )
    return None, f"{'child' if child else 'possibly a child'} ({who}); {facility}"


# --- the two lists ------------------------------------------------------------------------

Rule = tuple[str, str, ReferralTier, Callable[[ReferralInputs], Verdict]]
IMMEDIATE, CONSULT, REFER = ReferralTier.immediate, ReferralTier.consult, ReferralTier.refer

CURRENT: tuple[Rule, ...] = (
    ("aba2022.full_thickness", "Full-thickness burns (any size)", IMMEDIATE, full_thickness),
    ("aba2022.partial_ge_10", "Partial-thickness burns >= 10 %TBSA", IMMEDIATE, partial_at_least(10, strict=False)),
    (
        "aba2022.critical_areas_deep",
        "Deep partial-thickness or full-thickness burns of the face, hands, feet, genitalia, perineum "
        "or over major joints",
        IMMEDIATE,
        critical_areas(DEEP, "deep partial-thickness or full-thickness"),
    ),
    ("aba2022.inhalation", "Suspected inhalation injury", IMMEDIATE, inhalation),
    ("aba2022.chemical", "All chemical injuries", IMMEDIATE, chemical),
    (
        "aba2022.high_voltage",
        "High-voltage (>= 1000 V) electrical injuries and lightning injuries",
        IMMEDIATE,
        electrical(frozenset({"high"})),
    ),
    ("aba2022.trauma", "Burns with concomitant trauma", IMMEDIATE, trauma),
    (
        "aba2022.pediatric_safeguarding",
        "Pediatric burns (<= 14 years or < 30 kg) with suspected non-accidental trauma",
        IMMEDIATE,
        pediatric_safeguarding,
    ),
    ("aba2022.partial_lt_10", "Partial-thickness burns < 10 %TBSA", CONSULT, partial_below_10),
    ("aba2022.pediatric", "All pediatric burns (<= 14 years or < 30 kg)", CONSULT, pediatric),
    ("aba2022.low_voltage", "Low-voltage (< 1000 V) electrical injuries", CONSULT, electrical(frozenset({"low"}))),
    ("aba2022.comorbidities", "Burns in patients with significant comorbidities", CONSULT, comorbidities),
    (
        "aba2022.social_support",
        "Burns in patients who may need special social, emotional or rehabilitative support",
        CONSULT,
        social_needs,
    ),
)

OLDER: tuple[Rule, ...] = (
    (
        "aba2006.partial_gt_10",
        "Partial-thickness burns greater than 10 %TBSA",
        REFER,
        partial_at_least(10, strict=True),
    ),
    (
        "aba2006.critical_areas",
        "Burns that involve the face, hands, feet, genitalia, perineum or major joints",
        REFER,
        critical_areas(NOT_SUPERFICIAL, "partial-thickness or full-thickness"),
    ),
    ("aba2006.third_degree", "Third-degree (full-thickness) burns in any age group", REFER, full_thickness),
    (
        "aba2006.electrical",
        "Electrical burns, including lightning injury",
        REFER,
        electrical(frozenset({"high", "low"})),
    ),
    ("aba2006.chemical", "Chemical burns", REFER, chemical),
    ("aba2006.inhalation", "Inhalation injury", REFER, inhalation),
    (
        "aba2006.comorbidities",
        "Burn injury in patients with pre-existing medical disorders that could complicate management, "
        "prolong recovery or affect mortality",
        REFER,
        comorbidities,
    ),
    (
        "aba2006.trauma",
        "Burns with concomitant trauma in which the burn injury poses the greatest risk of morbidity or mortality",
        REFER,
        trauma_greatest_risk,
    ),
    (
        "aba2006.children_facility",
        "Burned children in hospitals without qualified personnel or equipment for the care of children",
        REFER,
        children_facility,
    ),
    (
        "aba2006.special_needs",
        "Burn injury in patients who will require special social, emotional or long-term rehabilitative "
        "intervention (including suspected child abuse)",
        REFER,
        social_needs,
    ),
)


def _judge(rules: tuple[Rule, ...], inp: ReferralInputs) -> list[CriterionResult]:
    results = []
    for code, text, tier, judge in rules:
        met, reason = judge(inp)
        results.append(CriterionResult(code=code, text=text, tier=tier, met=met, reason=reason))
    return results


def _unassessed(recommendation: str, undetermined: list[str]) -> str:
    if not undetermined:
        return recommendation
    return f"{recommendation}; not assessable from the record: {', '.join(undetermined)}"


def current_guideline(inp: ReferralInputs) -> GuidelineResult:
    criteria = _judge(CURRENT, inp)
    met = [c.code for c in criteria if c.met]
    undetermined = [c.code for c in criteria if c.met is None]
    if any(c.met and c.tier is IMMEDIATE for c in criteria):
        recommendation = "Immediate consultation with consideration for transfer"
    else:
        # Undetermined immediate criteria could still raise the tier: say which.
        open_immediate = [c.code for c in criteria if c.met is None and c.tier is IMMEDIATE]
        if met:
            recommendation = _unassessed("Consultation recommended", open_immediate)
        else:
            recommendation = _unassessed("No ABA referral criterion met on the recorded data", undetermined)
    return GuidelineResult(
        guideline=GUIDELINE,
        version=CURRENT_VERSION,
        criteria=criteria,
        met=met,
        recommendation=recommendation,
        undetermined=undetermined,
    )


def older_guideline(inp: ReferralInputs) -> GuidelineResult:
    criteria = _judge(OLDER, inp)
    met = [c.code for c in criteria if c.met]
    undetermined = [c.code for c in criteria if c.met is None]
    recommendation = (
        "Refer to a burn center" if met else _unassessed("No criterion met on the recorded data", undetermined)
    )
    return GuidelineResult(
        guideline=GUIDELINE,
        version=OLDER_VERSION,
        criteria=criteria,
        met=met,
        recommendation=recommendation,
        undetermined=undetermined,
    )


def assess_referral(inputs: ReferralInputs) -> ReferralAssessment:
    """Both referral guidelines judged on the same record."""
    return ReferralAssessment(current=current_guideline(inputs), older=older_guideline(inputs))
