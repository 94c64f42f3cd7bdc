"""A wound's measured share of the body beside the burn chart's estimate for its regions
(processing/clinical/wound_share.py): the figures, and when the measured share is flagged."""

from __future__ import annotations

import datetime as dt

import pytest

from processing.clinical.lund_browder import region_percent
from processing.clinical.wound_share import Charted, Measured, body_share
from schemas.burn_chart import AgeAdjustment, BurnChart, BurnChartEntry, BurnDepth, LundBrowderRegion

R = LundBrowderRegion
THIGH = [R.thigh_right_anterior]


def chart(*entries: tuple[LundBrowderRegion, float, BurnDepth]) -> Charted:
    value = BurnChart(
        encounter_id="0192f3b4-6a8e-7c3d-9b1a-2f4e5d6c7b99",
        assessed_at=dt.datetime(2026, 12, 1, tzinfo=dt.UTC),
        entries=[BurnChartEntry(region=r, fraction=f, depth=d) for r, f, d in entries],
    )
    return Charted(chart=value, age_years=36.0, described_as="burn_chart x version 1")


def measured(percent: float | None) -> Measured:
    return Measured(percent=percent, area_cm2=16.0, analysis="/api/v1/analyses/j", day=0.1)


def test_the_chart_share_is_the_charted_fraction_of_the_wounds_regions_at_every_depth():
    charted = chart(
        (R.thigh_right_anterior, 0.1, BurnDepth.superficial),  # counted here, though not in the %TBSA
        (R.thigh_right_anterior, 0.05, BurnDepth.deep_partial),
        (R.trunk_anterior, 0.5, BurnDepth.full_thickness),  # another wound's region: left out
    )
    share = body_share(THIGH, measured(0.5), charted)
    thigh = region_percent(R.thigh_right_anterior, 36.0, AgeAdjustment.band)
    assert share.charted_percent == pytest.approx(round(0.15 * thigh, 3))
    assert share.regions_percent == pytest.approx(round(thigh, 3)) and share.flag == ""
    assert share.charted_by == "burn_chart x version 1" and "Mosteller" in share.sources["measured"]


@pytest.mark.parametrize(
    ("percent", "flagged"),
    [
        (0.01, ""),  # smaller than charted: one capture often shows part of a burn
        (0.30, ""),  # a little larger: within the chart's and the measurement's slack
        (0.60, "clearly larger than the chart's estimate"),
        (5.00, "larger than the wound's regions themselves"),
        (None, ""),  # no height or weight: nothing to compare
    ],
)
def test_a_measured_share_clearly_larger_than_the_chart_is_flagged(percent, flagged):
    charted = chart((R.thigh_right_anterior, 0.06, BurnDepth.superficial_partial))  # 0.285 %TBSA
    share = body_share(THIGH, measured(percent), charted)
    assert (flagged in share.flag) if flagged else share.flag == ""
    if flagged:
        assert "not changed" in share.flag or "check" in share.flag


def test_no_burn_charted_in_the_regions_is_flagged_and_no_chart_is_not():
    empty = chart((R.trunk_anterior, 0.2, BurnDepth.superficial_partial))
    assert "records no burn in the wound's regions" in body_share(THIGH, measured(0.1), empty).flag
    alone = body_share(THIGH, measured(0.1), None)
    assert alone.charted_percent is None and alone.regions_percent is None and alone.flag == ""
    assert body_share([], measured(0.1), empty).flag == ""  # a wound the upgrade made, no regions yet
