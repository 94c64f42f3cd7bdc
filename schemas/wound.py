"""A wound: one burn of a patient, the unit that is photographed, measured and tracked until it closes.

A patient often has several burns; each is its own record (kind `wound`, parent the patient), living across the
patient's encounters. The gateway's checks of a wound (gateway/wounds/rules.py) go beyond its schema: a state
other than open needs its date, the regions are listed once each, times are not in the future.
"""

from __future__ import annotations

import datetime as dt
import enum
from typing import Annotated

import msgspec

from schemas.base import Id, LongText, Message, ShortText, Timestamp
from schemas.burn_chart import LundBrowderRegion
from schemas.record_parts import MechanismType


class WoundSide(enum.StrEnum):
    """The side of the body the wound is on, as the patient's own left and right."""

    left = "left"
    right = "right"
    midline = "midline"
    bilateral = "bilateral"


class WoundState(enum.StrEnum):
    """Where the wound stands in its course."""

    open = "open"
    """Not yet closed: the default for a new wound."""
    healing = "healing"
    """Closing by itself, not closed yet."""
    healed = "healed"
    """Closed by re-epithelialisation."""
    grafted = "grafted"
    """Closed by a skin graft."""
    closed_other = "closed_other"
    """Closed by another means (a flap, a substitute, amputation)."""

    @property
    def label(self) -> str:
        """How people say it: "healed", "closed by another means"."""
        return "closed by another means" if self is WoundState.closed_other else self.value


Regions = Annotated[
    list[LundBrowderRegion],
    msgspec.Meta(
        max_length=len(LundBrowderRegion),
        description="Each region once; at least one when written (a wound the upgrade made may have none yet).",
    ),
]

Label = Annotated[ShortText, msgspec.Meta(min_length=1)]
"""ShortText (at most 200 characters) that is not empty."""


class Wound(Message):
    """One burn of a patient, tracked from the day it is first seen until it closes."""

    id: Id
    """Made by the client, like a patient's: a UUID in canonical lower-case form."""
    patient_id: Id
    """The patient the wound belongs to; fixed once the wound is created."""
    regions: Regions
    """The Lund-Browder regions the wound covers, each listed once: the gateway needs at least one when the wound is
    written. Only a wound the upgrade made for earlier analyses can have none, until a clinician sets them."""
    label: Label
    """A short name people use for it ("left forearm"), unique enough to tell the patient's wounds apart."""
    side: WoundSide | None = None
    """Left, right, midline or bilateral; None when the regions already say it or it is not known."""
    site_detail: ShortText = ""
    """Where on the regions, in words ("ulnar border, 5 cm above the wrist")."""
    cause: MechanismType | None = None
    """What burned it (flame, scald, contact...); None when it is the encounter's mechanism or not known."""
    time_of_injury: Timestamp | None = None
    """When it was burned. Left out, the gateway fills it from the patient's most recent encounter (latest time of
    arrival, withdrawn ones left out) that records a time of injury; None when no encounter records one."""
    state: WoundState = WoundState.open
    """Open, healing, healed, grafted or closed by another means."""
    state_date: dt.date | None = None
    """The date the wound reached its state: required unless the state is open, and only then."""
    notes: LongText = ""
    """Anything else worth knowing about this wound."""


class AssetWound(Message):
    """PUT /api/v1/assets/{asset_id}/wound: which wound a picture shows."""

    wound_id: Id | None
    """A live wound of the encounter's patient; None says the picture shows no wound in particular."""
