"""Follow-up: the referral advice restated with its urgency, and the healing track's review prompts.

Depth re-assessment and the re-dressing schedule depend on the wound-care rules (wound_care.py).
"""

from __future__ import annotations

from processing.clinical.decision_inputs import DecisionInputs
from processing.clinical.sources import ABA_REFERRAL, DEITCH, KANTOR_MARGOLIS
from schemas.clinical_results import ReferralTier
from schemas.decision_support import InputUsed, Recommendation, RecommendationCategory

MISSING_REFERRAL = "referral assessment (needs the burn chart and the patient's age): no referral advice"


def referral(inputs: DecisionInputs) -> tuple[list[Recommendation], list[str]]:
    assessment = inputs.assessment
    result = assessment.value.referral if assessment else None
    if result is None:
        return [], [MISSING_REFERRAL]
    current = result.current
    met = [c for c in current.criteria if c.met]
    immediate = any(c.tier is ReferralTier.immediate for c in met)
    used = [assessment.used("referral criteria met", ", ".join(current.met) or "none")]
    if current.undetermined:
        used.append(assessment.used("referral criteria undetermined", ", ".join(current.undetermined)))
    head = current.recommendation.split("; not assessable")[0]
    text = f"Referral ({current.guideline}): {head}."
    details = [f"{c.text}: {c.reason}" for c in met]
    open_criteria = [c.text for c in current.criteria if c.met is None]
    if open_criteria:
        details.append("Not assessable from the record (record what is missing): " + "; ".join(open_criteria))
    return [
        Recommendation(
            key="follow_up.referral",
            category=RecommendationCategory.follow_up,
            text=text,
            details=details,
            inputs=used,
            source=ABA_REFERRAL,
            urgent=immediate,
        )
    ], []


def healing_prompts(inputs: DecisionInputs) -> list[Recommendation]:
    """One recommendation per published rule the healing track triggers (a prompt to review, not a verdict)."""
    track = inputs.track
    if track is None:
        return []
    refs = inputs.track_refs
    out = []
    for flag in track.stall_flags:
        if not (flag.evaluable and flag.triggered):
            continue
        deitch = flag.citation.startswith("Deitch")
        name = "kantor" if not deitch else "deitch_projected" if flag.rule.startswith("projected") else "deitch"
        used = [
            InputUsed(
                name="measured visit", value=f"{ref.kind} {ref.id}", kind=ref.kind, id=ref.id, version=ref.version
            )
            for ref in refs
        ]
        out.append(
            Recommendation(
                key=f"follow_up.healing.{name}",
                category=RecommendationCategory.follow_up,
                text=f"Review the healing plan: {flag.rule} ({flag.detail}).",
                details=[f"Source: {flag.citation}"],
                inputs=used,
                source=DEITCH if deitch else KANTOR_MARGOLIS,
            )
        )
    return out
