"""What the referral card of an encounter says, from the stored Assessment, in words a clinician uses.

A count of criteria met only means something once criteria have been judged: with nothing judged the card says
"Not assessed yet" and what it needs (most criteria read the burn chart); with some still open it says how many.
The recommendation is shown without the stored list of undetermined criterion codes (the page names their texts).
"""

from __future__ import annotations

from dataclasses import dataclass

from schemas.clinical_results import Assessment, ReferralTier

UNDETERMINED_SEPARATOR = "; not assessable"
"""Where processing/clinical/referral_rules.py appends the codes of the undetermined criteria to the recommendation."""

TIER_WORDS = {
    ReferralTier.immediate: "immediate consultation, consider transfer",
    ReferralTier.consult: "consultation recommended",
    ReferralTier.refer: "refer",
}
"""Each tier of a criterion met, as its badge says it."""


@dataclass(frozen=True)
class ReferralCard:
    value: str
    """The figure in large type: "2 criteria met", "None met", "Not assessed yet"."""
    meta: str
    """The line under it: the guideline, and what is still open."""
    recommendation: str
    """The recommendation in a sentence ("" before any assessment)."""


def _plural(n: int, one: str, many: str) -> str:
    return f"{n} {one if n == 1 else many}"


def referral_card(assessment: Assessment | None) -> ReferralCard:
    if assessment is None or assessment.referral is None:
        return ReferralCard("Not assessed yet", "needs the patient's age and the burn chart", "")
    result = assessment.referral.current
    judged = [c for c in result.criteria if c.met is not None]
    still_open = len(result.criteria) - len(judged)
    source = f"{result.guideline} {result.version}"
    recommendation = result.recommendation.split(UNDETERMINED_SEPARATOR)[0]
    if not judged:
        needs = "needs the burn chart" if assessment.tbsa is None else "needs more of the record"
        return ReferralCard("Not assessed yet", f"{needs} ({source})", recommendation)
    value = _plural(len(result.met), "criterion met", "criteria met") if result.met else "None met"
    if still_open:
        value = value if result.met else "None met so far"
        return ReferralCard(
            value, f"{source}; {_plural(still_open, 'criterion', 'criteria')} not judged yet", recommendation
        )
    return ReferralCard(value, source, recommendation)
