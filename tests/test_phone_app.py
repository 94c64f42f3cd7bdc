"""The phone companion app (/app/) in a real Chromium standing in for a phone (phone viewport, touch, a fake camera
fed from a video file) against a real gateway process on loopback: paired, signed in, then offline at the bedside a
patient, an encounter and a wound are made and photos taken with the camera; the page is closed and opened again
offline from the service worker; back in reach, every photo reaches the gateway byte for byte and its verdict comes
back to the phone."""

from __future__ import annotations

import hashlib
import re

import httpx
import pytest

from harness.browser import CHROMIUM, CHROMIUM_ARGS, browser_missing, shot
from harness.phone_app import (
    PHONE_PHOTOS,
    fake_camera,
    gateway_with_staff,
    pair_and_sign_in,
    pairing_code,
    phone_context,
    phone_photos,
    poll,
    staff_headers,
)

pytestmark = pytest.mark.skipif(bool(browser_missing()), reason=browser_missing() or "browser present")
PHOTOS = 8


@pytest.fixture(scope="module")
def gateway(tmp_path_factory):
    folder = tmp_path_factory.mktemp("phone")
    process = gateway_with_staff(folder)
    process.env["BURNEDGE_JOBS_WORKERS"] = "1"
    process.start()
    yield process, folder
    process.stop()


@pytest.fixture(scope="module")
def phone_browser(gateway):
    """Chromium with a fake rear camera playing the phantom's orbit, the camera permission granted."""
    from playwright.sync_api import sync_playwright

    camera = fake_camera(gateway[1])
    with sync_playwright() as playwright:
        args = [
            *CHROMIUM_ARGS,
            "--use-fake-ui-for-media-stream",
            "--use-fake-device-for-media-stream",
            f"--use-file-for-fake-video-capture={camera}",
        ]
        browser = playwright.chromium.launch(executable_path=str(CHROMIUM), headless=True, args=args)
        yield browser
        browser.close()


def test_a_nurse_pairs_captures_offline_and_nothing_is_lost(gateway, phone_browser):
    process, _ = gateway
    browser = phone_browser
    code = pairing_code(process.url)
    context = phone_context(browser, permissions=["camera"])
    page = context.new_page()
    try:
        # 1. Pair from the QR code's address, then sign in once for the shift.
        pair_and_sign_in(page, process.url, code)
        poll(page, "navigator.serviceWorker.controller !== null || navigator.serviceWorker.ready.then(() => true)")
        shot(page, "phone-patients", readme="app-patients.png")

        # 2.-3. Offline: the patient, the encounter (time of injury, mechanism) and the wound.
        context.set_offline(True)
        page.get_by_label("Given name").fill("Ana")
        page.get_by_label("Family name").fill("Offline")
        page.get_by_role("button", name="Add patient").click()
        page.get_by_role("heading", name="Ana Offline").wait_for()
        page.get_by_label("Time of injury").fill("2026-12-06T06:30")
        page.get_by_label("Mechanism").select_option("scald")
        page.get_by_role("button", name="Start encounter").click()
        page.get_by_role("heading", name="Photograph").wait_for()
        encounter_id = page.url.rsplit("/", 1)[-1]
        page.goto(page.url.replace(f"#/encounter/{encounter_id}", ""))  # back to the patient through the list
        page.get_by_role("link", name="Ana Offline").click()
        page.get_by_role("heading", name="Ana Offline").wait_for()  # the patient screen, not the list's form
        page.get_by_label("Name", exact=True).fill("left forearm")
        page.get_by_label("Regions").select_option(["lower_arm_left_anterior"])
        page.get_by_role("button", name="Add wound").click()
        page.get_by_text("left forearm").first.wait_for()
        shot(page, "phone-patient", readme="app-patient.png")

        # 4. The camera: stills from the live view go to the phone's queue at once.
        page.goto(f"{process.url}/app/#/encounter/{encounter_id}")
        page.get_by_role("link", name="Photograph left forearm").click()
        shutter = page.get_by_role("button", name="Take photo")
        shutter.wait_for()
        poll(page, "!document.getElementById('shutter').disabled", 30)
        # The gateway's checks run on the preview: the printed marker in the phantom's orbit is found.
        poll(page, "document.getElementById('check').textContent.includes('marker in view')", 60)
        for n in range(1, PHOTOS + 1):  # one still per view of the orbit (each plays for half a second)
            page.wait_for_timeout(500)
            shutter.click()
            if page.locator("#warn").is_visible():
                page.get_by_role("button", name="Take it anyway").click()
            page.get_by_text(f"{n} photos of left forearm on this phone").wait_for()
        shot(page, "phone-capture", readme="app-capture.png")
        taken = phone_photos(page)
        assert len(taken) == PHOTOS and all(p["state"] == "queued" for p in taken)
        # Each was judged on the phone before it left; the marker strip is in most views of the orbit.
        assert all(p["device_verdict"] for p in taken)
        assert sum(bool(p["device_verdict"]["figures"]["markers"]) for p in taken) >= 2
        assert page.locator(".ring .arc-done, .ring circle.arc-done").count() >= 1  # the ring fills

        # 5. Closed, and opened again with no connection: the service worker serves the app, the queue is there.
        page.close()
        page = context.new_page()
        page.goto(f"{process.url}/app/")
        page.get_by_role("heading", name="Patients").wait_for()
        poll(page, "document.getElementById('link-status').textContent.includes('offline')")
        poll(page, f"document.getElementById('queue-status').textContent.includes('{PHOTOS} photos waiting')")

        # 6. Back in reach: the records go first, then each photo, confirmed by its SHA-256, and its verdict.
        context.set_offline(False)
        page.evaluate("window.dispatchEvent(new Event('online'))")
        stored = poll(
            page,
            f"({PHONE_PHOTOS})().then((ps) => ps.length === {PHOTOS} && ps.every((p) => p.state === 'stored') && ps)",
            120,
        )
        page.goto(f"{process.url}/app/#/encounter/{encounter_id}")
        page.locator("[data-state=stored]").first.wait_for()
        assert page.locator("[data-state=stored]").count() == PHOTOS
        assert page.locator(".verdict").count() == PHOTOS  # the gateway's verdict on each, now on the phone
        shot(page, "phone-encounter", readme="app-encounter.png")

        # 7. The analysis, asked for from the phone; its result comes back through the change feed.
        page.get_by_role("button", name="Measure left forearm in 3D").click()
        page.get_by_text("Measurement asked for").wait_for()
        poll(page, "(window.dispatchEvent(new Event('online')), document.querySelector('#analyses li') !== null)", 300)
        result = page.locator("#analyses li").first.inner_text()
        # The report, kept on the phone: it opens offline.
        page.get_by_role("button", name="Keep the report on this phone").click()
        page.get_by_role("link", name="Open the report kept on this phone").wait_for()
        context.set_offline(True)
        page.reload()
        report = page.get_by_role("link", name="Open the report kept on this phone")
        head = page.evaluate(
            "(a) => fetch(a.href).then((r) => r.text()).then((t) => t.slice(0, 5))", report.element_handle()
        )
        assert head == "%PDF-"
        context.set_offline(False)
        shot(page, "phone-analysis", readme="app-analysis.png")
        for width, height, name in ((768, 1024, "tablet"), (1280, 900, "desktop")):
            page.set_viewport_size({"width": width, "height": height})
            shot(page, f"{name}-encounter")
    finally:
        context.close()

    headers = staff_headers(process.url)
    for photo in stored:
        asset = httpx.get(f"{process.url}/api/v1/assets/{photo['asset']['id']}", headers=headers).json()
        body = httpx.get(f"{process.url}/api/v1/assets/{asset['id']}/file", headers=headers).content
        assert hashlib.sha256(body).hexdigest() == photo["sha256"] == asset["sha256"]
        assert asset["encounter_id"] == encounter_id and asset["wound_id"]
        assert asset["metadata"]["captured_offset"]  # the phone's stated capture time, kept as a camera's
        assert photo["asset"]["verdict"]["file"]
    area = float(re.search(r"area ([0-9.]+) cm", result).group(1))
    assert 16.0 * 0.8 < area < 16.0 * 1.2, result  # the phantom's burn is 16 cm2: a measurement, not a stub
    record = httpx.get(f"{process.url}/api/v1/encounters/{encounter_id}/mechanism", headers=headers).json()
    assert record["data"]["type"] == "scald"
