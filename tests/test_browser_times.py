"""A nurse's phone on the clinic's Wi-Fi, in a real browser (Playwright driving Debian's Chromium) at phone width
with touch, against a real gateway process whose clinic is in Nairobi (UTC+3) while the phone is set to Berlin:
the time fields name the clinic's zone, the phone is told it is set to another one, a time of injury in the future
comes back on the form with what was typed and the error beside the field, and the corrected time is stored in UTC
as the clinic wall time typed (issue 38)."""

from __future__ import annotations

import datetime as dt
import re
import zoneinfo

import httpx
import pytest

from harness.browser import PHONE, browser_missing, shot
from harness.processes import add_user_cli, login
from tests.test_browser_clinic import expect, sign_in

pytestmark = pytest.mark.skipif(bool(browser_missing()), reason=browser_missing() or "browser present")
NAIROBI = zoneinfo.ZoneInfo("Africa/Nairobi")  # UTC+3, no daylight saving
PHONE_ZONE = "Europe/Berlin"


def _offset_text(zone: str) -> str:
    minutes = round(dt.datetime.now(zoneinfo.ZoneInfo(zone)).utcoffset().total_seconds() / 60)
    sign = "+" if minutes >= 0 else "-"
    return f"UTC{sign}{abs(minutes) // 60:02d}:{abs(minutes) % 60:02d}"


def test_a_phone_in_another_zone_types_clinic_time_and_a_future_time_comes_back_on_the_form(gateway_process, browser):
    gateway_process.env["BURNEDGE_GATEWAY_TIMEZONE"] = "Africa/Nairobi"
    add_user_cli(gateway_process.db, "nina", "nurse")
    gateway_process.start()
    context = browser.new_context(
        viewport={"width": PHONE[0], "height": PHONE[1]}, is_mobile=True, has_touch=True, timezone_id=PHONE_ZONE
    )
    page = context.new_page()
    problems: list[str] = []
    page.on("console", lambda m: problems.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: problems.append(str(e)))
    clinic = gateway_process.url

    sign_in(page, clinic, "nina")
    page.get_by_role("link", name="New patient").tap()
    page.get_by_label("Given name").fill("Wanjiru")
    page.get_by_role("button", name="Create patient").tap()
    page.wait_for_url(re.compile(r"/patients/[0-9a-f-]+$"))
    page.get_by_role("link", name="New encounter").tap()

    injury = page.get_by_label("Time of injury (Africa/Nairobi, UTC+03:00)")
    expect(injury).to_be_visible()
    expect(page.locator("#field-time_of_injury-help")).to_contain_text(
        "Up to 5 minutes ahead of the clinic clock is accepted."
    )
    note = page.locator("#field-time_of_injury-zone")
    expect(note).to_be_visible()
    expect(note).to_have_text(f"This device is set to {_offset_text(PHONE_ZONE)}; enter clinic time (UTC+03:00).")
    assert page.get_by_label("Mode").input_value() == "", "the mode is the clinician's choice, never preset"

    wall = dt.datetime.now(NAIROBI).replace(second=0, microsecond=0, tzinfo=None)
    ahead = (wall + dt.timedelta(hours=2)).strftime("%Y-%m-%dT%H:%M")
    page.get_by_label("Mode").select_option("emergency")
    page.get_by_label("Time of arrival").fill(wall.strftime("%Y-%m-%dT%H:%M"))
    injury.fill(ahead)
    page.get_by_label("Clinician").fill("Nurse Nina")
    page.get_by_role("button", name="Open encounter").tap()
    page.wait_for_load_state()

    assert page.url.endswith("/encounters/new"), "the form comes back, not an error page"
    error = page.locator("#field-time_of_injury-error")
    expect(error).to_contain_text("is in the future: 2 h 00 min ahead of the clinic clock")
    expect(page.locator(".error-summary a[href='#field-time_of_injury']")).to_be_visible()
    assert injury.get_attribute("aria-invalid") == "true"
    assert injury.input_value() == ahead and page.get_by_label("Clinician").input_value() == "Nurse Nina"
    assert page.get_by_label("Mode").input_value() == "emergency"
    # The error sits right under the field's label, beside the input, on a 390 px screen.
    field_box, error_box = injury.bounding_box(), error.bounding_box()
    assert 0 < field_box["y"] - (error_box["y"] + error_box["height"]) < 120
    assert page.evaluate("document.documentElement.scrollWidth") <= PHONE[0], "nothing wider than the phone"
    shot(page, "times-01-future-injury-refused", full_page=True)

    typed = (wall - dt.timedelta(hours=1, minutes=15)).strftime("%Y-%m-%dT%H:%M")
    injury.fill(typed)
    page.get_by_role("button", name="Open encounter").tap()
    page.wait_for_url(re.compile(r"/encounters/[0-9a-f-]+$"))
    encounter_id = page.url.rsplit("/", 1)[1]
    shown = (wall - dt.timedelta(hours=1, minutes=15)).strftime("%Y-%m-%d %H:%M")
    assert f"injured {shown} EAT" in page.inner_text("main"), "shown again in clinic time"
    shot(page, "times-02-encounter-saved")

    with httpx.Client(base_url=clinic) as api:
        data = api.get(f"/api/v1/encounters/{encounter_id}", headers=login(api, "nina")).json()["data"]
    stored = dt.datetime.fromisoformat(data["time_of_injury"])
    assert stored.utcoffset() == dt.timedelta(0), f"stored in UTC, not {data['time_of_injury']}"
    assert stored.astimezone(NAIROBI).replace(tzinfo=None) == wall - dt.timedelta(hours=1, minutes=15)
    assert [p for p in problems if "status of 422" not in p] == [], problems  # the refused form's own status
    context.close()
