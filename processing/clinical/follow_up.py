"""Follow-up: the referral advice restated with its urgency, and the healing track's review prompts.

The depth re-assessment and the 2-week not-healed referral count from the time of injury.
"""

from __future__ import annotations

import datetime as dt

from processing.clinical.decision_inputs import DecisionInputs
from processing.clinical.referral_rules import NOT_ASSESSABLE
from processing.clinical.sources import ABA_REFERRAL, BBA_NOT_HEALED, DEITCH, KANTOR_MARGOLIS, VICBURNS_DEPTH
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
    open_criteria = [c.text for c in current.criteria if c.met is None]
    used = [assessment.used("referral criteria met", "; ".join(c.text for c in met) or "none")]
    if open_criteria:
        used.append(assessment.used("referral criteria undetermined", "; ".join(open_criteria)))
    head = current.recommendation.split(NOT_ASSESSABLE)[0]
    text = f"Referral ({current.guideline}): {head}."
    details = [f"{c.text}: {c.reason}" for c in met]
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


REASSESS_H = 48.0
DEPTH_UNCLEAR_DAYS = 5.0
NOT_HEALED_DAYS = 14


def timing(inputs: DecisionInputs) -> tuple[list[Recommendation], list[str]]:
    """Depth re-assessment within 48 h (shown for the first 5 days), and the 2-week not-healed referral."""
    injury, days = inputs.injury_time, inputs.days_since_injury()
    if inputs.chart is None:
        return [], []
    if injury is None or days is None:
        return [], ["time of injury: the follow-up dates are not worked out"]
    used = [
        inputs.encounter.used("time of injury", injury),
        inputs.chart.used("burn chart assessed", inputs.chart.value.assessed_at),
    ]
    out = []
    if days < DEPTH_UNCLEAR_DAYS:
        by = (injury + dt.timedelta(hours=REASSESS_H)).strftime("%Y-%m-%d %H:%M UTC")
        out.append(
            Recommendation(
                key="follow_up.depth_reassessment",
                category=RecommendationCategory.follow_up,
                text=f"Re-assess the burn depth, ideally within 48 hours of the injury (by {by}): depth evolves as "
                "exudate and oedema settle. Refer if the depth is still unclear after 3-5 days.",
                inputs=used,
                source=VICBURNS_DEPTH,
            )
        )
    by = (injury + dt.timedelta(days=NOT_HEALED_DAYS)).strftime("%Y-%m-%d")
    out.append(
        Recommendation(
            key="follow_up.not_healed_2_weeks",
            category=RecommendationCategory.follow_up,
            text=f"Refer to a burn service if the burn is not healed in 2 weeks (by {by}).",
            inputs=used,
            source=BBA_NOT_HEALED,
        )
    )
    return out, []


def healing_prompts(inputs: DecisionInputs) -> list[Recommendation]:
    """One recommendation per published rule a wound's healing track triggers (a prompt to review, not a verdict).
    With several wounds, each is named and keyed by its own id."""
    out = []
    several = len(inputs.tracks) > 1
    for wound in inputs.tracks:
        for flag in wound.track.stall_flags:
            if not (flag.evaluable and flag.triggered):
                continue
            deitch = flag.citation.startswith("Deitch")
            name = "kantor" if not deitch else "deitch_projected" if flag.rule.startswith("projected") else "deitch"
            used = [
                InputUsed(
                    name="measured visit", value=f"{ref.kind} {ref.id}", kind=ref.kind, id=ref.id, version=ref.version
                )
                for ref in wound.refs
            ]
            of = f" of the {wound.label}" if several else ""
            key = f"follow_up.healing.{name}" + (f".{wound.wound_id}" if several and wound.wound_id else "")
            out.append(
                Recommendation(
                    key=key,
                    category=RecommendationCategory.follow_up,
                    text=f"Review the healing plan{of}: {flag.rule} ({flag.detail}).",
                    details=[f"Source: {flag.citation}"],
                    inputs=used,
                    source=DEITCH if deitch else KANTOR_MARGOLIS,
                )
            )
    return out
