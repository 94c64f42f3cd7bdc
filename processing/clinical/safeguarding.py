"""Safeguarding: a child's burn whose pattern or account calls for a safeguarding assessment.

NICE CG89 names the alerting features of burns and scalds in under-18s: no suitable explanation, a child who is not
independently mobile, a site not expected to touch a hot object by accident, the shape of an implement, and signs
of forced immersion. NICE's "suspect" is a serious level of concern, not proof: the wording says so, and names the
features recorded, never a person. A concern the intake records (social context) counts as well.
"""

from __future__ import annotations

from processing.clinical.decision_inputs import DecisionInputs
from processing.clinical.sources_major import NICE_CHILD_MALTREATMENT
from schemas.decision_support import InputUsed, Recommendation, RecommendationCategory

UNDER_YEARS = 18.0
"""NICE CG89 covers children and young people under 18."""
ASK = "safeguarding questions (does the account fit the burn; its pattern; can the child move about alone)"


def recommend(inputs: DecisionInputs) -> tuple[list[Recommendation], list[str]]:
    age = inputs.age_years
    if age is None or age >= UNDER_YEARS or inputs.chart is None:
        return [], []
    features: list[InputUsed] = []
    m = inputs.mechanism
    if m is not None:
        if m.value.account_fits_injury is False:
            features.append(m.used("the account given does not fit the burn", True))
        if m.value.pattern_of_concern is True:
            features.append(m.used("a burn pattern that needs an explanation", True))
        if m.value.child_independently_mobile is False:
            features.append(m.used("the child cannot move about alone", True))
    intake = inputs.intake
    if intake is not None and intake.value.social.safeguarding_concern:
        features.append(intake.used("safeguarding concern recorded", True))
    unjudged = m is None or m.value.account_fits_injury is None or m.value.pattern_of_concern is None
    missing = [f"{ASK}: not recorded for this child"] if unjudged else []
    if not features:
        return [], missing
    text = (
        "Safeguarding: the record shows features that NICE asks clinicians to act on in a child's burn ("
        + "; ".join(f.name for f in features)
        + "). Arrange a safeguarding assessment under local child-protection procedures, with the senior clinician "
        "or safeguarding lead. This is a concern to look into, not a finding."
    )
    details = [
        "Record the account of how it happened in the words used, who gave it, and when; photograph the burn's edges.",
        "NICE: to suspect maltreatment is a serious level of concern about its possibility, not proof of it; other "
        "explanations stay open.",
    ]
    return [
        Recommendation(
            key="safeguarding.child",
            category=RecommendationCategory.safeguarding,
            text=text,
            details=details,
            inputs=[*features, inputs.age_used()],
            source=NICE_CHILD_MALTREATMENT,
        )
    ], missing
