"""Opioids for a severe burn or pain that is not controlled: IV, titrated, by age; the route follows the setting.

Severe burn: over 20 %TBSA, a formal fluid resuscitation, suspected inhalation injury or a high-voltage injury (the
Victorian Adult Burns Service's definition, with the fluid threshold standing in for children). IV is the route: IM,
SC and oral doses are absorbed unreliably after a burn. Adults: morphine 2-5 mg IV every 5 minutes, titrated to
response (Victorian Adult Burns Service; it gives no per-kg dose and no maximum). Children from 1 year: morphine
0.05-0.1 mg/kg IV, repeated 5-minutely until effective, each dose capped here at the adult 5 mg; with morphine
blocked by an allergy, IV fentanyl 0.5-2 microgram/kg, initial maximum 50 microgram (Perth Children's Hospital,
which offers fentanyl or morphine). No adult alternative is given by the sources checked: the text says so.
"""

from __future__ import annotations

from processing.clinical.airway import signs_present
from processing.clinical.decision_inputs import ADULT_FROM_YEARS, DecisionInputs
from processing.clinical.mechanism_care import ELECTRICAL, high_voltage
from processing.clinical.pain_allergy import allergy_to
from processing.clinical.sources_major import PCH_BURNS_ANALGESIA, VICBURNS_ANALGESIA
from schemas.decision_support import InputUsed, Recommendation, RecommendationCategory

CHILD_IV_FROM_YEARS = 1.0
SEVERE_OVER_TBSA = 20.0
MORPHINE_CHILD_MG_PER_KG = (0.05, 0.1)
ADULT_INCREMENT_MG = (2.0, 5.0)
FENTANYL_CHILD_MCG_PER_KG = (0.5, 2.0)
FENTANYL_CHILD_INITIAL_MAX_MCG = 50.0
ROUTE = "IV is the route: IM, SC and oral doses are absorbed unreliably after a burn."


def severity(inputs: DecisionInputs) -> list[InputUsed]:
    """Why this is a severe burn, as facts; empty when it is not (or cannot be told)."""
    why: list[InputUsed] = []
    assessment = inputs.assessment
    tbsa = assessment.value.tbsa if assessment is not None else None
    plan = assessment.value.fluids if assessment is not None else None
    if tbsa is not None and tbsa.tbsa_percent > SEVERE_OVER_TBSA:
        why.append(assessment.used("%TBSA", f"{tbsa.tbsa_percent:g} %"))
    elif plan is not None and plan.formal_resuscitation_indicated:
        why.append(assessment.used("formal fluid resuscitation indicated", True))
    signs = signs_present(inputs)
    if signs:
        why.append(signs[0])
    if inputs.mechanism is not None and inputs.mechanism.value.type in ELECTRICAL and high_voltage(inputs):
        why.append(inputs.mechanism.used("high-voltage injury", True))
    return why


def recommend(inputs: DecisionInputs, weight: float | None, base: list[InputUsed]) -> Recommendation | None:
    age = inputs.age_years
    severe = severity(inputs)
    primary = inputs.primary
    uncontrolled = primary is not None and primary.value.pain_poorly_controlled is True
    adult = age is not None and age >= ADULT_FROM_YEARS
    if age is None or age < CHILD_IV_FROM_YEARS or not (severe or (uncontrolled and adult)):
        return None
    used = [*base, *severe]
    if uncontrolled:
        used.append(primary.used("pain poorly controlled", True))
    why = "severe burn" if severe else "pain not controlled"
    iv = primary.value.circulation.iv_access if primary is not None else False
    if primary is not None:
        used.append(primary.used("IV access", iv))
    blocked = allergy_to(inputs, "morphine")
    details = [ROUTE, "Reassess the pain score after each dose; aim for a pain score of 4 or less at rest."]
    source = VICBURNS_ANALGESIA
    if blocked is not None:
        used.append(blocked[1])
        text, alt_source = _morphine_blocked(inputs, weight, why, blocked[0])
        source = alt_source or source
    elif adult:
        low, high = ADULT_INCREMENT_MG
        text = (
            f"Pain ({why}): morphine {low:g}-{high:g} mg IV every 5 minutes, titrated to the response; consider an "
            "infusion once controlled. The source gives no maximum: watch breathing and sedation."
        )
    elif weight is None:
        text = f"Pain ({why}): morphine 0.05-0.1 mg/kg IV; no dose shown: the child's weight is not recorded."
        source = PCH_BURNS_ANALGESIA
    else:
        low, high = (min(k * weight, ADULT_INCREMENT_MG[1]) for k in MORPHINE_CHILD_MG_PER_KG)
        capped = " (capped at the adult 5 mg)" if high < MORPHINE_CHILD_MG_PER_KG[1] * weight else ""
        text = (
            f"Pain ({why}): morphine {low:.2g}-{high:.2g} mg IV (0.05-0.1 mg/kg × {weight:g} kg{capped}), repeated "
            "every 5 minutes until effective."
        )
        source = PCH_BURNS_ANALGESIA
    if not iv:
        text += " No IV access is recorded: gain IV access for analgesia."
        if not adult:
            details.append("Meanwhile, intranasal fentanyl (see its recommendation) where the child's pain is severe.")
    return Recommendation(
        key="pain.opioid",
        category=RecommendationCategory.pain,
        text=text,
        details=details,
        inputs=used,
        source=source,
        urgent=True,
    )


def _morphine_blocked(inputs: DecisionInputs, weight: float | None, why: str, allergy: str):
    head = f"Pain ({why}): morphine is not advised: allergy recorded to {allergy}."
    if inputs.age_years >= ADULT_FROM_YEARS:
        return (
            head + " The sources checked give no adult alternative: choose another analgesic with senior advice.",
            None,
        )
    fentanyl = allergy_to(inputs, "fentanyl")
    if fentanyl is not None:
        return head + f" Fentanyl, the source's alternative, is blocked too ({fentanyl[0]}): seek senior advice.", None
    if weight is None:
        return head + " IV fentanyl 0.5-2 microgram/kg instead; no dose shown: the weight is not recorded.", (
            PCH_BURNS_ANALGESIA
        )
    low, high = (k * weight for k in FENTANYL_CHILD_MCG_PER_KG)
    first = min(high, FENTANYL_CHILD_INITIAL_MAX_MCG)
    return (
        head + f" IV fentanyl instead: {min(low, first):.0f}-{first:.0f} microgram (0.5-2 microgram/kg × {weight:g} kg,"
        f" first dose at most {FENTANYL_CHILD_INITIAL_MAX_MCG:g} microgram); half the dose may be repeated every 3-5 "
        "minutes.",
        PCH_BURNS_ANALGESIA,
    )
