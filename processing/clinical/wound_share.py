"""A wound's measured area as a share of the body, beside the burn chart's estimate for the wound's regions.

The two come from different places: the analysis measures the burn surface in the photos (area over the
patient's Mosteller BSA, stored with the analysis as metrics.tbsa_percent); the chart is a clinician's estimate by
Lund-Browder. Setting them side by side checks the chart, as a second estimate does. A measured share clearly larger
than the chart allows is flagged for the clinician to look at both; the chart is never changed from here, and a
measured share smaller than the chart's is not flagged (one capture often shows only part of a burn).
"""

from __future__ import annotations

from dataclasses import dataclass

from processing.clinical.lund_browder import region_percent
from schemas.burn_chart import BurnChart, LundBrowderRegion
from schemas.wound_healing import BodyShare

CLEARLY_LARGER_RATIO = 1.25
"""The measured share must exceed the charted one by more than a quarter: 3D areas on the phantoms are within about
10 %, and a charted fraction of a region is rarely finer than a tenth of it."""
CLEARLY_LARGER_POINTS = 0.02
"""...and by more than 0.02 %TBSA (about 4 cm2 on an adult, several times the 3D area's error on a small burn), so
that a tiny burn charted as a sliver of a region is not flagged for its rounding."""
DIGITS = 3
"""%TBSA shown to 3 decimals: a 10 cm2 burn is about 0.005 % of an adult's body."""


@dataclass(frozen=True)
class Measured:
    """The wound's latest measured visit."""

    percent: float | None
    area_cm2: float
    analysis: str
    day: float


@dataclass(frozen=True)
class Charted:
    """The burn chart the wound is compared with, and the age its Lund-Browder columns are read at."""

    chart: BurnChart
    age_years: float
    described_as: str
    """Which record and version, and which encounter: "the burn chart of the encounter of 1 Dec 2026 (version 3)"."""


def body_share(regions: list[LundBrowderRegion], measured: Measured, charted: Charted | None) -> BodyShare:
    """The measured share, the chart's share of the same regions, and a flag when the first is clearly larger."""
    charted_percent = regions_percent = None
    if charted is not None and regions:
        method, age = charted.chart.age_adjustment, charted.age_years
        wanted = set(regions)
        entries = [e for e in charted.chart.entries if e.region in wanted]
        charted_percent = sum(region_percent(e.region, age, method) * e.fraction for e in entries)
        regions_percent = sum(region_percent(r, age, method) for r in wanted)
    return BodyShare(
        measured_percent=_rounded(measured.percent),
        measured_area_cm2=measured.area_cm2,
        measured_by=measured.analysis,
        measured_day=measured.day,
        charted_percent=_rounded(charted_percent),
        regions_percent=_rounded(regions_percent),
        charted_by=charted.described_as if charted is not None else "",
        flag=_flag(measured.percent, charted_percent, regions_percent, bool(regions)),
    )


def _rounded(percent: float | None) -> float | None:
    return None if percent is None else round(percent, DIGITS)


def _flag(measured: float | None, charted: float | None, whole: float | None, has_regions: bool) -> str:
    if measured is None or not has_regions:
        return ""
    if whole is not None and measured > whole:
        return (
            f"The measured area ({measured:.3f} %TBSA) is larger than the wound's regions themselves ({whole:.3f} "
            "%TBSA): check the wound's regions and the scale (marker) of the analysis."
        )
    if charted is None:
        return ""
    if charted == 0:
        return (
            f"The burn chart records no burn in the wound's regions, but {measured:.3f} %TBSA was measured there: "
            "check the chart and the wound's regions."
        )
    if measured > charted * CLEARLY_LARGER_RATIO and measured - charted > CLEARLY_LARGER_POINTS:
        return (
            f"The measured area ({measured:.3f} %TBSA) is clearly larger than the chart's estimate for the wound's "
            f"regions ({charted:.3f} %TBSA): review the chart against the photos; the chart is not changed."
        )
    return ""
