"""The consultants' case list in a real browser against `burnedge central` on loopback, over a center holding a
few hundred cases from three clinics: paging on, filtering by urgency and clinic through the form, at phone,
tablet and desktop widths."""

from __future__ import annotations

import re

import pytest

from harness.browser import DESKTOP, PHONE, TABLET, browser_missing, shot
from harness.case_seed import seeded_center
from harness.processes import PASSWORD
from harness.sites import CenterProcess

pytestmark = pytest.mark.skipif(bool(browser_missing()), reason=browser_missing() or "browser available")


@pytest.fixture(scope="module")
def center(tmp_path_factory):
    center = seeded_center(tmp_path_factory.mktemp("center"), 130).start()
    yield center
    center.stop()


def latest(center: CenterProcess, where: str = "1 = 1", params: tuple = ()) -> int:
    return center.rows(f"SELECT COUNT(*) FROM bundles WHERE superseded_by IS NULL AND {where}", params)[0][0]


@pytest.mark.parametrize("size", [PHONE, TABLET, DESKTOP], ids=["phone", "tablet", "desktop"])
def test_a_consultant_pages_through_the_cases_and_filters_them_by_urgency_and_clinic(center, browser, size):
    from playwright.sync_api import expect

    page = browser.new_page(viewport={"width": size[0], "height": size[1]})
    page.goto(center.url + "/cases")
    page.get_by_label("Username").fill("consult")
    page.get_by_label("Password").fill(PASSWORD)
    page.get_by_role("button", name="Sign in").click()
    page.wait_for_url(re.compile(r"/cases$"))

    total = latest(center)
    rows = page.locator("tbody tr")
    expect(page.locator(".count")).to_have_text(f"{total} cases")
    expect(rows).to_have_count(50)
    first_page = rows.locator("a").evaluate_all("links => links.map(a => a.getAttribute('href'))")
    shot(page, f"center-cases-{size[0]}", full_page=False)

    page.get_by_role("link", name="Next 50 cases").click()
    expect(page.get_by_role("link", name="first page")).to_be_visible()
    second_page = rows.locator("a").evaluate_all("links => links.map(a => a.getAttribute('href'))")
    assert len(second_page) == min(50, total - 50) and not set(first_page) & set(second_page)

    page.get_by_label("Urgency").select_option("immediate")
    page.get_by_label("Clinic").select_option(label="Clinic 1")
    page.get_by_role("button", name="Show").click()
    page.wait_for_url(re.compile(r"urgency=immediate"))
    picked = latest(center, "urgency = ? AND site_id = ?", ("immediate", "clinic-001"))
    assert 0 < picked < 50
    expect(page.locator(".count")).to_have_text(f"{picked} cases match these filters")
    expect(rows).to_have_count(picked)
    expect(rows.locator(".badge-urgent")).to_have_count(picked)
    assert set(rows.locator("td[data-label=Clinic]").all_inner_texts()) == {"Clinic 1"}
    shot(page, f"center-cases-filtered-{size[0]}", full_page=False)

    page.get_by_role("link", name="Clear filters").click()
    expect(page.locator(".count")).to_have_text(f"{total} cases")
    page.close()
