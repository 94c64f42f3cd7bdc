"""The burn chart: Lund-Browder regions, each with the fraction burned and its depth."""

from __future__ import annotations

import enum
from typing import Annotated

import msgspec

from schemas.base import Fraction, Id, Message, Timestamp


class BurnDepth(enum.StrEnum):
    """Clinical burn-depth category, as judged by the clinician.

    Never derived from 3D geometry: measured "surface relief" is a different thing.
    """

    superficial = "superficial"
    """Epidermal only; excluded from %TBSA."""
    superficial_partial = "superficial_partial"
    deep_partial = "deep_partial"
    full_thickness = "full_thickness"


class LundBrowderRegion(enum.StrEnum):
    """Regions of the Lund-Browder chart, split front/back as on the printed chart."""

    head_anterior = "head_anterior"
    head_posterior = "head_posterior"
    neck_anterior = "neck_anterior"
    neck_posterior = "neck_posterior"
    trunk_anterior = "trunk_anterior"
    trunk_posterior = "trunk_posterior"
    buttock_right = "buttock_right"
    buttock_left = "buttock_left"
    genitalia = "genitalia"
    upper_arm_right_anterior = "upper_arm_right_anterior"
    upper_arm_right_posterior = "upper_arm_right_posterior"
    upper_arm_left_anterior = "upper_arm_left_anterior"
    upper_arm_left_posterior = "upper_arm_left_posterior"
    lower_arm_right_anterior = "lower_arm_right_anterior"
    lower_arm_right_posterior = "lower_arm_right_posterior"
    lower_arm_left_anterior = "lower_arm_left_anterior"
    lower_arm_left_posterior = "lower_arm_left_posterior"
    hand_right_palmar = "hand_right_palmar"
    hand_right_dorsal = "hand_right_dorsal"
    hand_left_palmar = "hand_left_palmar"
    hand_left_dorsal = "hand_left_dorsal"
    thigh_right_anterior = "thigh_right_anterior"
    thigh_right_posterior = "thigh_right_posterior"
    thigh_left_anterior = "thigh_left_anterior"
    thigh_left_posterior = "thigh_left_posterior"
    lower_leg_right_anterior = "lower_leg_right_anterior"
    lower_leg_right_posterior = "lower_leg_right_posterior"
    lower_leg_left_anterior = "lower_leg_left_anterior"
    lower_leg_left_posterior = "lower_leg_left_posterior"
    foot_right_dorsal = "foot_right_dorsal"
    foot_right_plantar = "foot_right_plantar"
    foot_left_dorsal = "foot_left_dorsal"
    foot_left_plantar = "foot_left_plantar"


_PARTS = {"upper_arm": "upper arm", "lower_arm": "forearm", "lower_leg": "lower leg"}
_FACES = {"anterior": "front", "posterior": "back", "palmar": "palm", "dorsal": "back"}
_R = LundBrowderRegion
_SINGLE = {_R.head_anterior: "Head, front", _R.head_posterior: "Head, back", _R.neck_anterior: "Neck, front"}
_SINGLE |= {_R.neck_posterior: "Neck, back", _R.trunk_anterior: "Trunk, front", _R.trunk_posterior: "Trunk, back"}
_SINGLE |= {_R.genitalia: "Genitalia", _R.buttock_right: "Right buttock", _R.buttock_left: "Left buttock"}


def _region_name(region: LundBrowderRegion) -> str:
    if region in _SINGLE:
        return _SINGLE[region]
    part, side, face = region.value.rsplit("_", 2)
    if part == "foot":
        return f"{side.capitalize()} foot, {'top' if face == 'dorsal' else 'sole'}"
    return f"{side.capitalize()} {_PARTS.get(part, part)}, {_FACES[face]}"


REGION_NAMES: dict[LundBrowderRegion, str] = {region: _region_name(region) for region in LundBrowderRegion}
"""Region -> its name for a reader, e.g. "Right thigh, front", "Left hand, palm", "Right foot, sole": what pages,
the PDF and the center show (the codes are for machines)."""


def region_name(region: LundBrowderRegion | str) -> str:
    """A region's name for a reader, from the region or its code."""
    return REGION_NAMES[LundBrowderRegion(region)]


class SpecialArea(enum.StrEnum):
    """Functionally or cosmetically critical areas named by the referral criteria."""

    face = "face"
    hands = "hands"
    feet = "feet"
    genitalia = "genitalia"
    perineum = "perineum"
    major_joint = "major_joint"


class BurnChartEntry(Message):
    region: LundBrowderRegion
    fraction: Fraction
    """Share of this region that is burned at this depth (0 to 1)."""
    depth: BurnDepth
    circumferential: bool = False


class SpecialAreaInvolvement(Message):
    area: SpecialArea
    depth: BurnDepth


class AgeAdjustment(enum.StrEnum):
    band = "band"
    """Step: use the chart column of the age band the patient falls in (as on the printed chart)."""
    interpolate = "interpolate"
    """Linear between the chart's column ages (0, 1, 5, 10, 15, adult taken as 18)."""


class BurnChart(Message):
    """One clinician's charting of an encounter's burns. A region may appear once per depth."""

    encounter_id: Id
    assessed_at: Timestamp
    entries: list[BurnChartEntry] = []
    special_areas: list[SpecialAreaInvolvement] = []
    """Critical areas the regions alone cannot show (face, perineum, joints)."""
    age_adjustment: AgeAdjustment = AgeAdjustment.band


Percent = Annotated[float, msgspec.Meta(ge=0, le=100)]


class RegionCharting(Message):
    """The burn chart page's editor for one region: the share of the region burned at each depth, in percent of
    the region (not of the body). The page turns it into the chart's entries for that region."""

    superficial_partial_percent: Percent = 0.0
    """The share of this region, in percent, burned to superficial partial thickness."""
    deep_partial_percent: Percent = 0.0
    """The share of this region, in percent, burned to deep partial thickness."""
    full_thickness_percent: Percent = 0.0
    """The share of this region, in percent, burned to full thickness."""
    superficial_percent: Percent = 0.0
    """The share of this region, in percent, with a superficial (epidermal) burn only: charted, but not counted in
    the %TBSA."""
    circumferential: bool = False
    """The burn goes all the way round (limb or trunk): escharotomy may be needed."""

    def __post_init__(self) -> None:
        total = (
            self.superficial_partial_percent
            + self.deep_partial_percent
            + self.full_thickness_percent
            + self.superficial_percent
        )
        if total > 100.0 + 1e-9:
            raise ValueError(f"the depths add up to {total:g} % of the region: at most 100 %")
