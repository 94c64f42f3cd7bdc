"""The patient's wounds on the case page: each wound with this encounter's analyses of it and its latest area (from
the bundle's summary), and, when the clinic sent healing.json, its measured share of the body beside the burn
chart's, each with its source, and the clinic's check when it flags one.

A bundle sent before wounds were kept has neither wounds.json nor healing.json: the page says nothing of wounds.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import msgspec

from processing.views.body_chart_svg import REGION_LABELS
from schemas.records import Record
from schemas.transfer import CaseSummary
from schemas.wound import Wound
from schemas.wound_healing import SHARE_SOURCES, BodyShare, PatientHealing

WOUNDS_PART = "wounds.json"
HEALING_PART = "healing.json"


@dataclass
class WoundView:
    label: str
    regions: list[str]
    """The Lund-Browder regions as people say them ("Left upper arm, front")."""
    side: str
    state: str
    analyses: int
    """This encounter's analyses of the wound."""
    area_cm2: float | None
    """The latest of those with a metric scale."""
    share: list[tuple[str, str]] = field(default_factory=list)
    """The share measured in 3D and the chart's, each with its source; empty without healing.json or before the
    wound's first measured visit in cm²."""
    flag: str = ""
    """Why the measured share looks clearly larger than the chart allows (the clinic's check); empty when it does
    not."""


@dataclass
class WoundsView:
    wounds: list[WoundView]
    healing_sent: bool
    """Whether the bundle holds healing.json (clinic versions before it do not send it)."""
    unreadable: list[str] = field(default_factory=list)
    """Parts this center's version could not read, with why."""


def wounds_view(summary: CaseSummary, wounds_part: bytes, healing_part: bytes | None) -> WoundsView:
    try:
        wounds = [msgspec.convert(r.data, Wound) for r in msgspec.json.decode(wounds_part, type=list[Record])]
    except msgspec.DecodeError as exc:  # ValidationError included
        return WoundsView([], healing_part is not None, [f"wounds: this center's version could not read them ({exc})"])
    shares: dict[str | None, BodyShare] = {}
    unreadable = []
    if healing_part is not None:
        try:
            healing = msgspec.json.decode(healing_part, type=PatientHealing)
            shares = {w.wound_id: w.share for w in healing.wounds if w.share is not None}
        except msgspec.DecodeError as exc:
            unreadable.append(f"healing: this center's version could not read it ({exc})")
    counted = {w.wound_id: w for w in summary.wounds}
    views = []
    for wound in wounds:
        count = counted.get(wound.id)
        share = shares.get(wound.id)
        views.append(
            WoundView(
                label=wound.label,
                regions=[REGION_LABELS[r] for r in wound.regions],
                side=wound.side.value if wound.side else "",
                state=wound.state.label,
                analyses=count.analyses if count else 0,
                area_cm2=count.area_cm2 if count else None,
                share=share_rows(share) if share else [],
                flag=share.flag if share else "",
            )
        )
    return WoundsView(views, healing_part is not None, unreadable)


def share_rows(share: BodyShare) -> list[tuple[str, str]]:
    """The share measured in 3D beside the burn chart's, each naming its source (the clinic's report says the same)."""
    measured = (
        f"{share.measured_percent:.2f} %TBSA ({share.measured_area_cm2:.1f} cm² on day {share.measured_day:g}; "
        f"{SHARE_SOURCES['measured']})"
        if share.measured_percent is not None
        else f"not computed: the patient's height or weight is not recorded ({share.measured_area_cm2:.1f} cm²)"
    )
    charted = "no burn chart (with the patient's age) to compare with"
    if share.charted_percent is not None and share.regions_percent is not None:
        charted = (
            f"{share.charted_percent:.2f} %TBSA of the wound's regions ({share.regions_percent:.2f} %TBSA in all); "
            + "; ".join(filter(None, [SHARE_SOURCES["charted"], share.charted_by]))
        )
    return [("Share measured in 3D", measured), ("Share on the burn chart", charted)]
