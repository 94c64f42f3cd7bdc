"""The older burn-center referral guideline: the ABA/ACS 2006 single list of ten criteria.

Source: American Burn Association / American College of Surgeons, Guidelines for the Operation
of Burn Centers (2006), burn center referral criteria. Any criterion met means refer.
"""

from __future__ import annotations

from processing.clinical.referral_rules import (
    GUIDELINE,
    NO_INTAKE,
    NOT_SUPERFICIAL,
    NOTHING_JUDGED,
    REFER,
    ReferralInputs,
    Rule,
    Verdict,
    chemical,
    child_status,
    comorbidities,
    critical_areas,
    electrical,
    facial_burns,
    full_thickness,
    judge_rules,
    major_injuries,
    partial_at_least,
    strong_airway_signs,
    trauma,
    unassessed,
)
from schemas.clinical_results import GuidelineResult
from schemas.record_parts import Intake

OLDER_VERSION = "ABA/ACS Guidelines for the Operation of Burn Centers (2006) — single list"


def inhalation(inp: ReferralInputs) -> Verdict:
    """Inhalation injury: any airway sign, or facial burns (any depth) with an enclosed-space injury."""
    signs = []
    primary = inp.primary
    if primary is not None:
        signs += ["singed nasal hair"] if primary.airway.singed_nasal_hair else []
        signs += strong_airway_signs(primary)
    # Any depth: a superficial facial flash burn in an enclosed space is still a warning sign.
    if facial_burns(inp) and inp.mechanism is not None and inp.mechanism.enclosed_space:
        signs.append("facial burns with an enclosed-space injury")
    if signs:
        return True, "; ".join(signs)
    if primary is None:
        return None, "no primary survey recorded (airway signs of inhalation)"
    return False, "no sign of inhalation injury recorded"


def _social_needs(intake: Intake) -> list[str]:
    social = intake.social
    flags = [
        (social.safeguarding_concern, "safeguarding concern (possible non-accidental injury)"),
        (social.substance_use, "substance use"),
        (social.needs_rehabilitation_support, "special social, emotional or rehabilitative needs"),
    ]
    return [label for flag, label in flags if flag]


def social_needs(inp: ReferralInputs) -> Verdict:
    if inp.intake is None:
        return None, NO_INTAKE
    needs = _social_needs(inp.intake)
    return (
        (True, "; ".join(needs)) if needs else (False, "no special social, emotional or rehabilitative need recorded")
    )


def trauma_greatest_risk(inp: ReferralInputs) -> Verdict:
    met, reason = trauma(inp)
    if met is not True:
        return met, reason
    injuries = "; ".join(major_injuries(inp))
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
    child, who = child_status(inp)
    if child is False:
        return False, f"not a child ({who})"
    facility = (
        "depends on whether this facility has qualified personnel and equipment for burned children, "
        "which the record cannot show: decide locally"
    )
    return None, f"{'child' if child else 'possibly a child'} ({who}); {facility}"


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


def older_guideline(inp: ReferralInputs) -> GuidelineResult:
    criteria = judge_rules(OLDER, inp)
    met = [c.code for c in criteria if c.met]
    undetermined = [c.code for c in criteria if c.met is None]
    open_all = [c for c in criteria if c.met is None]
    if met:
        recommendation = "Refer to a burn center"
    elif len(open_all) == len(criteria):
        recommendation = unassessed(NOTHING_JUDGED, open_all)
    else:
        recommendation = unassessed("No criterion met on the recorded data", open_all)
    return GuidelineResult(
        guideline=GUIDELINE,
        version=OLDER_VERSION,
        criteria=criteria,
        met=met,
        recommendation=recommendation,
        undetermined=undetermined,
    )
