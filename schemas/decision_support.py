"""Decision support: recommendations computed from an encounter's record, each pending until a clinician acts.

The `decision_support` record (one per encounter, written by the gateway only) holds every recommendation with the
record versions it was computed from. A clinician marks each one accepted, or declined with a reason; that act
writes the record's next version and enters the audit chain. Recomputing keeps an act only where the
recommendation's text and inputs are unchanged (processing/clinical/decision_support.py).
"""

from __future__ import annotations

import enum
from typing import Literal

import msgspec

from schemas.base import Frozen, Id, Message, ShortText, Timestamp
from schemas.clinical_results import InputRef

DECISION_SUPPORT_NOTICE = (
    "Decision support only, never an order: each recommendation is confirmed, adapted or declined by the "
    "treating clinician."
)


class RecommendationCategory(enum.StrEnum):
    airway = "airway"
    """The airway at risk from inhalation injury."""
    breathing = "breathing"
    """Oxygen for carbon monoxide; a chest burn that restricts breathing."""
    circulation = "circulation"
    """Circulation to burned limbs: neurovascular checks, escharotomy."""
    mechanism = "mechanism"
    """Care that depends on how the burn happened: electrical, chemical."""
    temperature = "temperature"
    """Keeping a patient with a large burn warm."""
    safeguarding = "safeguarding"
    tetanus = "tetanus"
    wound_care = "wound_care"
    pain = "pain"
    fluids = "fluids"
    infection = "infection"
    follow_up = "follow_up"

    @property
    def label(self) -> str:
        return {"wound_care": "wound care", "follow_up": "follow-up"}.get(self.value, self.value)


class RecommendationState(enum.StrEnum):
    pending = "pending"
    """Not yet seen to by a clinician."""
    accepted = "accepted"
    declined = "declined"
    """Declined, with the clinician's reason."""


class Source(Frozen):
    """Where a rule comes from, precisely enough for a reader to find it."""

    guideline: str
    """Title and publisher, e.g. "CDC/ACIP: Prevention of pertussis, tetanus, and diphtheria with vaccines"."""
    section: str
    """Section, table or recommendation number."""
    year: int | None = None
    """Year of the version read; None for an undated web page (see `accessed`)."""
    url: str = ""
    accessed: str = ""
    """When an undated web page was read (YYYY-MM-DD)."""


class InputUsed(Frozen):
    """One fact a recommendation used: its name, value as shown, and the record version it came from."""

    name: str
    value: str
    kind: str
    """The record kind it was read from ("intake", "patient", "assessment", ...)."""
    id: Id
    version: int


class Recommendation(Frozen):
    key: str
    """Stable name of the rule that made it, e.g. "tetanus.vaccine": a recomputation finds its earlier act by it."""
    category: RecommendationCategory
    text: str
    """What to consider, in plain words for the clinician."""
    source: Source
    details: list[str] = msgspec.field(default_factory=list)
    """Doses, lines of a plan, or what blocked a drug, in the order to read them."""
    inputs: list[InputUsed] = msgspec.field(default_factory=list)
    urgent: bool = False
    """To be seen to now (e.g. tetanus immune globulin, a fluid plan running, an immediate referral)."""
    state: RecommendationState = RecommendationState.pending
    decided_by: ShortText | None = None
    decided_at: Timestamp | None = None
    reason: str | None = None
    """Why it was declined (required then), or a note on accepting it."""


class DecisionSupport(Frozen):
    """The `decision_support` record of an encounter."""

    encounter_id: Id
    computed_at: Timestamp
    as_of: Timestamp
    """The clock time the time-dependent rules (cooling window, days since injury) were judged at."""
    inputs: list[InputRef]
    """Every record version the rules read."""
    recommendations: list[Recommendation]
    missing: list[str] = msgspec.field(default_factory=list)
    """What the record lacks for a rule that could therefore not be applied, and why it matters."""
    notice: str = DECISION_SUPPORT_NOTICE


class RecommendationAct(Message):
    """A clinician's act on one recommendation (the body of POST .../decision-support/acts)."""

    key: ShortText
    state: Literal["accepted", "declined"]
    reason: str = ""
    """Required when declining: why, in the clinician's words (at most 2000 characters)."""
