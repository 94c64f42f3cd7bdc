"""The current burn-center referral guideline: the ABA 2022 two-tier table.

Source: American Burn Association, Guidelines for Burn Patient Referral, 2022
(https://www.ameriburn.org/burn-care-team/resources/guidelines-for-burn-patient-referral).
The table below follows the published two columns, "Immediate consultation with consideration
for transfer" and "Consultation recommended", row by row (thermal, inhalation, pediatrics,
chemical, electrical). The table must be checked against the current published version by the
clinical lead, and again whenever the ABA revises the page; how each row is read from the record
is said below and in each criterion's reason.

How the rows are read from the record:
- "suspected inhalation injury" (immediate) is the stronger airway signs: carbonaceous sputum,
  soot in mouth or nose, hoarse voice, stridor, oropharyngeal oedema, carboxyhaemoglobin > 10 %,
  or an airway secured by intubation or a surgical airway;
- "signs of potential inhalation" (consult) are facial burns of any depth (a possible flash burn),
  singed facial or nasal hair, and smoke exposure (a flame burn in an enclosed space);
- "all potentially deep burns of any size" (consult) is any deep partial-thickness burn charted
  (full-thickness burns are already in the immediate tier);
- "all pediatric burns" (immediate) is any burn in a child (<= 14 years, i.e. before the 15th
  birthday, or < 30 kg by default: children.aba_pediatric);
  a recorded safeguarding concern (possible non-accidental trauma) is named in the reason.
The published table has no row for special social, emotional or rehabilitative needs: that item
stays on the older list only (referral_aba2006).
"""

from __future__ import annotations

from processing.clinical.referral_rules import (
    CONSULT,
    DEEP,
    DEEP_PARTIAL,
    GUIDELINE,
    IMMEDIATE,
    NO_CHART,
    NO_INTAKE,
    NOTHING_JUDGED,
    ReferralInputs,
    Rule,
    Verdict,
    burned_anywhere,
    burned_regions,
    chemical,
    child_status,
    comorbidities,
    critical_areas,
    electrical,
    facial_burns,
    full_thickness,
    judge_rules,
    partial_at_least,
    partial_size,
    strong_airway_signs,
    trauma,
    unassessed,
)
from schemas.burn_chart import BurnDepth, SpecialArea
from schemas.clinical_results import GuidelineResult
from schemas.record_parts import MechanismType

CURRENT_VERSION = "ABA 2022 (two-tier)"


def partial_below_10(inp: ReferralInputs) -> Verdict:
    size = partial_size(inp)
    if isinstance(size, tuple):
        return size
    if size >= 10:
        return False, f"partial-thickness burns {size:.2f} %TBSA (>= 10: immediate tier)"
    return size > 0, f"partial-thickness burns {size:.2f} %TBSA (< 10)"


def potentially_deep(inp: ReferralInputs) -> Verdict:
    if inp.chart is None:
        return None, NO_CHART
    where = burned_anywhere(inp.chart, DEEP_PARTIAL)
    if not where:
        return False, "no deep partial-thickness burn charted (full-thickness burns are judged in the immediate tier)"
    size = f" {inp.tbsa.deep_partial_percent:.2f} %TBSA" if inp.tbsa is not None else ""
    return True, f"deep partial-thickness burns{size} ({'; '.join(where)}): potentially deep"


def pain(inp: ReferralInputs) -> Verdict:
    if inp.primary is None:
        return None, "no primary survey recorded: record whether pain is controlled"
    controlled = inp.primary.pain_poorly_controlled
    if controlled is None:
        return None, "record whether pain is controlled"
    if controlled:
        return True, "pain poorly controlled with the analgesia available"
    return False, "pain recorded as controlled"


def inhalation_suspected(inp: ReferralInputs) -> Verdict:
    if inp.primary is None:
        return None, "no primary survey recorded (airway signs of inhalation)"
    signs = strong_airway_signs(inp.primary)
    if signs:
        return True, "; ".join(signs)
    return False, "no sign of suspected inhalation injury recorded"


def inhalation_potential(inp: ReferralInputs) -> Verdict:
    signs = []
    if facial_burns(inp):
        signs.append("facial burns (a possible flash burn)")
    if inp.primary is not None and inp.primary.airway.singed_nasal_hair:
        signs.append("singed facial or nasal hair")
    mechanism = inp.mechanism
    if mechanism is not None and mechanism.enclosed_space and MechanismType(mechanism.type) is MechanismType.flame:
        signs.append("smoke exposure (flame burn in an enclosed space)")
    if signs:
        return True, "; ".join(signs)
    missing = []
    if inp.primary is None:
        missing.append("no primary survey recorded (singed hair)")
    if mechanism is None:
        missing.append("no mechanism of injury recorded (smoke exposure)")
    if missing:
        return None, "; ".join(missing)
    return False, "no facial burn, singed facial or nasal hair, or smoke exposure recorded"


def pediatric(inp: ReferralInputs) -> Verdict:
    child, who = child_status(inp)
    if child is False:
        return False, f"not a child ({who})"
    concern = inp.intake is not None and inp.intake.social.safeguarding_concern
    safeguarding = "; safeguarding concern recorded (possible non-accidental trauma)" if concern else ""
    if child is None:
        return None, f"the patient's age or weight is needed ({who}){safeguarding}"
    if inp.chart is not None:
        burned = burned_regions(inp.chart, frozenset(BurnDepth))
        burned = burned or [SpecialArea(s.area).value for s in inp.chart.special_areas]
        if burned:
            return True, f"child ({who}) with burns charted ({'; '.join(burned)}){safeguarding}"
    if inp.mechanism is not None:
        kind = MechanismType(inp.mechanism.type).value
        return True, f"child ({who}) with a burn injury ({kind}){safeguarding}"
    if concern:
        return True, f"child ({who}){safeguarding}"
    if inp.chart is not None:
        return False, f"child ({who}), but no burn charted"
    missing = NO_CHART if inp.intake is not None else f"{NO_CHART}; {NO_INTAKE}"
    return None, f"child ({who}); {missing}"


CURRENT: tuple[Rule, ...] = (
    # Immediate consultation with consideration for transfer
    ("aba2022.full_thickness", "Thermal: full-thickness burns (any size)", IMMEDIATE, full_thickness),
    (
        "aba2022.partial_ge_10",
        "Thermal: partial-thickness burns >= 10 %TBSA",
        IMMEDIATE,
        partial_at_least(10, strict=False),
    ),
    (
        "aba2022.critical_areas_deep",
        "Thermal: any deep partial-thickness or full-thickness burn involving the face, hands, genitalia, feet, "
        "perineum or over any joint",
        IMMEDIATE,
        critical_areas(DEEP, "deep partial-thickness or full-thickness"),
    ),
    ("aba2022.comorbidities", "Thermal: patients with burns and other comorbidities", IMMEDIATE, comorbidities),
    ("aba2022.trauma", "Thermal: patients with burns and concomitant traumatic injuries", IMMEDIATE, trauma),
    ("aba2022.pain", "Thermal: poorly controlled pain", IMMEDIATE, pain),
    (
        "aba2022.inhalation",
        "Inhalation: all patients with suspected inhalation injury",
        IMMEDIATE,
        inhalation_suspected,
    ),
    (
        "aba2022.pediatric",
        "Pediatrics (<= 14 years or < 30 kg): all pediatric burns (burn-center care for pain, dressing changes, "
        "rehabilitation, patient or caregiver needs, or non-accidental trauma)",
        IMMEDIATE,
        pediatric,
    ),
    ("aba2022.chemical", "Chemical: all chemical injuries", IMMEDIATE, chemical),
    (
        "aba2022.high_voltage",
        "Electrical: all high-voltage (>= 1000 V) electrical injuries; lightning injury",
        IMMEDIATE,
        electrical(frozenset({"high"})),
    ),
    # Consultation recommended
    ("aba2022.partial_lt_10", "Thermal: partial-thickness burns < 10 %TBSA", CONSULT, partial_below_10),
    ("aba2022.potentially_deep", "Thermal: all potentially deep burns of any size", CONSULT, potentially_deep),
    (
        "aba2022.inhalation_potential",
        "Inhalation: signs of potential inhalation injury such as facial flash burns, singed facial hair "
        "or smoke exposure",
        CONSULT,
        inhalation_potential,
    ),
    (
        "aba2022.low_voltage",
        "Electrical: low-voltage (< 1000 V) electrical injuries",
        CONSULT,
        electrical(frozenset({"low"})),
    ),
)


def current_guideline(inp: ReferralInputs) -> GuidelineResult:
    criteria = judge_rules(CURRENT, inp)
    met = [c.code for c in criteria if c.met]
    undetermined = [c.code for c in criteria if c.met is None]
    if any(c.met and c.tier is IMMEDIATE for c in criteria):
        recommendation = "Immediate consultation with consideration for transfer"
    else:
        # Undetermined immediate criteria could still raise the tier: say which.
        open_immediate = [c for c in criteria if c.met is None and c.tier is IMMEDIATE]
        open_all = [c for c in criteria if c.met is None]
        if met:
            recommendation = unassessed("Consultation recommended", open_immediate)
        elif len(open_all) == len(criteria):
            recommendation = unassessed(NOTHING_JUDGED, open_all)
        else:
            recommendation = unassessed("No ABA referral criterion met on the recorded data", open_all)
    return GuidelineResult(
        guideline=GUIDELINE,
        version=CURRENT_VERSION,
        criteria=criteria,
        met=met,
        recommendation=recommendation,
        undetermined=undetermined,
    )
