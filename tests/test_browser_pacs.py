"""A clinician sends an analysed encounter to the hospital's PACS from the encounter page, in a real browser at phone
width (Playwright driving Debian's Chromium, 390 px), against a real gateway process and a real Orthanc: the page
shows the send's state, nothing on it is wider than the phone, and Orthanc holds the study. The screenshot is saved
as a test artifact (harness/browser.py)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from litestar.testing import TestClient

from harness.browser import PHONE, browser_missing, shot
from harness.orthanc import USER as PACS_USER
from harness.page_fit import FIT_SCRIPT, LONGEST_WORD
from harness.processes import PASSWORD, GatewayProcess, free_port
from tests.dicom_clinic import Clinic

pytestmark = pytest.mark.skipif(bool(browser_missing()), reason=browser_missing() or "browser present")


def expect(locator):
    from playwright.sync_api import expect as playwright_expect

    return playwright_expect(locator)


def test_a_clinician_sends_the_encounter_to_the_pacs_from_the_page_at_phone_width(orthanc, browser, tmp_path):
    clinic = Clinic(tmp_path, orthanc.dicomweb_url)
    with TestClient(clinic.app) as http:
        encounter_id = clinic.analysed_encounter(http)
    gateway = GatewayProcess(Path(clinic.config.gateway.database), free_port())
    gateway.env.update(
        {
            "BURNEDGE_DICOM_ENDPOINT": orthanc.dicomweb_url,
            "BURNEDGE_DICOM_USERNAME": PACS_USER,
            "BURNEDGE_DICOM_PASSWORD_FILE": clinic.config.dicom.password_file,
        }
    )
    gateway.start()
    context = browser.new_context(viewport={"width": PHONE[0], "height": PHONE[1]})
    try:
        page = context.new_page()
        page.goto(gateway.url + "/")
        page.wait_for_url(re.compile(r"/sign-in"))
        page.get_by_label("Username").fill("clin")
        page.get_by_label("Password").fill(PASSWORD)
        page.get_by_role("button", name="Sign in").click()
        page.wait_for_load_state()
        page.goto(f"{gateway.url}/encounters/{encounter_id}")
        panel = page.locator("#pacs")
        expect(panel).to_contain_text("Not sent to the hospital's PACS")
        panel.get_by_role("button", name="Send to the hospital's PACS").click()
        page.wait_for_url(re.compile(rf"/encounters/{encounter_id}#pacs$"))
        expect(panel.locator('[data-pacs-state="sent"]')).to_be_visible()
        expect(panel).to_contain_text("5 objects")
        # The page does not scroll sideways and no word of the PACS panel is broken or sticks out at 390 px.
        assert page.evaluate(FIT_SCRIPT, [LONGEST_WORD, "#pacs h2, #pacs li, #pacs p, #pacs button"]) == []
        panel.scroll_into_view_if_needed()
        shot(page, "pacs-sent-phone", full_page=False)
        with orthanc.client() as pacs:
            stats = pacs.get("/statistics").json()
        assert (stats["CountPatients"], stats["CountStudies"], stats["CountInstances"]) == (1, 1, 5)
    finally:
        context.close()
        gateway.stop()
