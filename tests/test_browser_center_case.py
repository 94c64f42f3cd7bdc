"""The case page in a real browser against `burnedge central` on loopback, over a case a clinic sent for real
(tests/center_pair.py, then the center's own process over the same database and store): the history with the
allergy first, ABCDE, the body chart and the recommendations urgent first, at phone and desktop widths."""

from __future__ import annotations

import re

import pytest

from harness.browser import DESKTOP, PHONE, browser_missing, shot
from harness.processes import PASSWORD, free_port
from harness.sites import CenterProcess
from tests.center_pair import center_pair
from tests.center_record import full_record

pytestmark = pytest.mark.skipif(bool(browser_missing()), reason=browser_missing() or "browser available")


@pytest.fixture(scope="module")
def center(tmp_path_factory):
    folder = tmp_path_factory.mktemp("pair")
    with center_pair(folder) as pair:
        case_url = pair.send(full_record(pair))
    center = CenterProcess(folder, free_port(), free_port()).start()
    yield center, case_url
    center.stop()


@pytest.mark.parametrize("size", [PHONE, DESKTOP], ids=["phone", "desktop"])
def test_a_consultant_reads_the_clinics_record_on_the_case_page(center, browser, size):
    from playwright.sync_api import expect

    process, case_url = center
    page = browser.new_page(viewport={"width": size[0], "height": size[1]})
    page.goto(process.url + case_url)
    page.get_by_label("Username").fill("consult")
    page.get_by_label("Password").fill(PASSWORD)
    page.get_by_role("button", name="Sign in").click()
    page.wait_for_url(re.compile(re.escape(case_url) + "$"))

    history = page.locator("#history")
    expect(history.get_by_role("heading")).to_have_text("Allergies, medications, tetanus and history")
    expect(history).to_contain_text("Morphine — reaction: severe itching and vomiting")
    expect(history).to_contain_text("Warfarin — dose: 3 mg at night")
    expect(history).to_contain_text("Last dose on 2013-05-20")
    expect(page.locator("#primary-survey")).to_contain_text("GCS 15 (E4 V5 M6)")
    chart = page.locator("#burn-chart svg")
    expect(chart).to_be_visible()
    assert chart.bounding_box()["width"] > 0.5 * min(size[0], 600)
    recommendations = page.locator("#decision-support li.recommendation")
    expect(recommendations.first).to_have_class(re.compile(r"\burgent\b"))
    classes = recommendations.evaluate_all("items => items.map(li => li.classList.contains('urgent'))")
    assert classes == sorted(classes, reverse=True)  # every urgent one before the others
    shot(page, f"center-case-{size[0]}")
    page.close()
