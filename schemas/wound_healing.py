"""Healing per wound: each wound's own track, and its measured area as a share of the body beside the burn chart.

GET /api/v1/wounds/{id}/healing answers a WoundHealing; GET /api/v1/patients/{id}/healing a PatientHealing, one
section per wound. Decision support only: the share measured in 3D is the surface in the photos, the chart's is a
clinician's estimate; neither replaces the other, and the chart is never changed from here.
"""

from __future__ import annotations

import msgspec

from schemas.base import Frozen
from schemas.burn_chart import LundBrowderRegion
from schemas.longitudinal import TrackResult

SHARE_SOURCES = {
    "measured": "the wound's latest measured area (3D, cm2) over the patient's body surface area (Mosteller, from "
    "the height and weight recorded)",
    "charted": "the burn chart's Lund-Browder estimate for the wound's regions (every depth charted, superficial "
    "included), for the patient's age",
}


class BodyShare(Frozen):
    """The wound's measured area as a share of the body, beside the burn chart's estimate for its regions."""

    measured_percent: float | None
    """Latest measured area over the body surface area (%TBSA); None when height or weight is missing."""
    measured_area_cm2: float
    """The area it is computed from (cm2)."""
    measured_by: str
    """The analysis it comes from (/api/v1/analyses/{id})."""
    measured_day: float
    """The track's day of that visit."""
    charted_percent: float | None
    """The chart's burned share of the wound's regions (%TBSA, every depth); None when no chart is recorded."""
    regions_percent: float | None
    """The whole of the wound's regions (%TBSA) at the patient's age: no burn in them can be larger."""
    charted_by: str = ""
    """The burn chart (record and version) and the encounter it belongs to; empty when there is none."""
    flag: str = ""
    """Why the measured share looks clearly larger than the chart allows; empty when it does not. A prompt for the
    clinician to look at the chart and the photos, never a correction of either."""
    sources: dict[str, str] = msgspec.field(default_factory=lambda: dict(SHARE_SOURCES))


class WoundHealing(Frozen):
    """One wound's healing track, computed from that wound's analyses only."""

    wound_id: str | None
    """None for the section of analyses made for a patient with no wound recorded."""
    label: str
    regions: list[LundBrowderRegion] = msgspec.field(default_factory=list)
    state: str = "open"
    """open, healing, healed, grafted or closed_other (the wound record's state)."""
    track: TrackResult | None = None
    """None until the wound has a measured visit."""
    share: BodyShare | None = None
    """None until the wound has a measured visit in cm2."""


class PatientHealing(Frozen):
    """A patient's healing: one section per wound, never mixed."""

    patient_id: str
    wounds: list[WoundHealing]
    """Each live wound in the order recorded, then analyses that belong to no wound (if any)."""
