"""Decision support for one encounter: every rule's recommendations, and clinicians' acts carried over.

Pure: the recommendations depend only on the inputs (the record versions read, and the clock time the
time-dependent rules are judged at). Each recommendation starts pending. `carry_over` keeps a clinician's act
(accepted, or declined with a reason) only where the recommendation's key, text, details and input values are
unchanged: an act on different advice is not an act on this advice. Versions of the inputs are provenance, not
content: re-saving a record with the same values keeps the act.
"""

from __future__ import annotations

import datetime as dt

import msgspec

from processing.clinical import (
    airway,
    circulation,
    fluid_advice,
    follow_up,
    infection,
    mechanism_care,
    oxygen,
    pain,
    safeguarding,
    temperature,
    tetanus,
    wound_care,
)
from processing.clinical.decision_inputs import DecisionInputs
from schemas.decision_support import DecisionSupport, Recommendation, RecommendationAct, RecommendationState
from schemas.errors import InvalidInput

RULES = (
    airway.recommend,
    oxygen.recommend,
    circulation.recommend,
    temperature.recommend,
    mechanism_care.recommend,
    wound_care.recommend,
    tetanus.recommend,
    pain.recommend,
    fluid_advice.recommend,
    infection.recommend,
    follow_up.referral,
    follow_up.timing,
    safeguarding.recommend,
)
MAX_REASON = 2000


def recommend(inputs: DecisionInputs, computed_at: dt.datetime) -> DecisionSupport:
    recommendations: list[Recommendation] = []
    missing: list[str] = []
    for rule in RULES:
        made, lacking = rule(inputs)
        recommendations += made
        missing += lacking
    recommendations += follow_up.healing_prompts(inputs)
    # Urgent first, as the sources order care (airway, breathing, circulation before the rest); stable otherwise.
    recommendations.sort(key=lambda r: not r.urgent)
    keys = [r.key for r in recommendations]
    if len(set(keys)) != len(keys):
        raise ValueError(f"two rules made recommendations with the same key: {keys}")
    return DecisionSupport(
        encounter_id=inputs.encounter.value.id,
        computed_at=computed_at,
        as_of=inputs.as_of,
        inputs=inputs.refs(),
        recommendations=recommendations,
        missing=missing,
    )


def _content(r: Recommendation) -> tuple:
    return (r.key, r.text, tuple(r.details), tuple((i.kind, i.name, i.value) for i in r.inputs))


def carry_over(previous: DecisionSupport | None, fresh: DecisionSupport) -> DecisionSupport:
    """`fresh` with the acts of `previous` kept on the recommendations whose content is unchanged."""
    if previous is None:
        return fresh
    acted = {r.key: r for r in previous.recommendations if r.state is not RecommendationState.pending}
    kept = []
    for r in fresh.recommendations:
        old = acted.get(r.key)
        if old is not None and _content(old) == _content(r):
            r = msgspec.structs.replace(
                r, state=old.state, decided_by=old.decided_by, decided_at=old.decided_at, reason=old.reason
            )
        kept.append(r)
    return msgspec.structs.replace(fresh, recommendations=kept)


def same_advice(a: DecisionSupport, b: DecisionSupport) -> bool:
    """Whether two computations say the same thing (computed_at, as_of and input versions aside)."""
    return [(_content(r), r.state, r.reason) for r in a.recommendations] == [
        (_content(r), r.state, r.reason) for r in b.recommendations
    ] and a.missing == b.missing


def apply_act(current: DecisionSupport, act: RecommendationAct, who: str, at: dt.datetime) -> DecisionSupport:
    """The record with one recommendation accepted or declined. Declining needs a reason."""
    reason = act.reason.strip()
    if act.state == RecommendationState.declined.value and not reason:
        raise InvalidInput("say why the recommendation is declined (reason)")
    if len(reason) > MAX_REASON:
        raise InvalidInput(f"the reason is {len(reason)} characters long; at most {MAX_REASON}")
    keys = [r.key for r in current.recommendations]
    if act.key not in keys:
        raise InvalidInput(f"no recommendation '{act.key}' in this encounter's decision support (it has: {keys})")
    updated = [
        msgspec.structs.replace(
            r, state=RecommendationState(act.state), decided_by=who, decided_at=at, reason=reason or None
        )
        if r.key == act.key
        else r
        for r in current.recommendations
    ]
    return msgspec.structs.replace(current, recommendations=updated)
