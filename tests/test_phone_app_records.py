"""The phone app's records in a real Chromium against a real gateway process: an injury changed on the phone while
someone changed it at the gateway is shown as a conflict, field by field, and settled by the nurse; the change feed
keeps the phone within its bound of patients; a gateway serving a new version of the app updates the phone, says
so, and the photo waiting on the phone still reaches the gateway."""

from __future__ import annotations

import hashlib
import shutil

import httpx
import pytest

from gateway.phones.app_routes import APP_DIR
from harness.browser import browser_missing, shot
from harness.phone_app import (
    PHONE_PHOTOS,
    gateway_with_staff,
    pair_and_sign_in,
    pairing_code,
    phone_context,
    poll,
    staff_headers,
)
from harness.sites import noise_photo
from schemas.ids import uuid7 as new_id

pytestmark = pytest.mark.skipif(bool(browser_missing()), reason=browser_missing() or "browser present")
PATIENT_BOUND = 300
"""The phone's bound (gateway/phones/app/js/sync.js)."""

PHONE_RECORDS = """async (kind) => {
  const db = await new Promise((ok, fail) => { const r = indexedDB.open("burnedge-app"); r.onsuccess = () => ok(r.result); r.onerror = fail; });
  const all = await new Promise((ok) => { const r = db.transaction("records").objectStore("records").getAll(); r.onsuccess = () => ok(r.result); });
  db.close();
  return all.filter((r) => r.kind === kind).map((r) => r.id);
}"""


@pytest.fixture
def gateway(tmp_path):
    process = gateway_with_staff(tmp_path)
    yield process
    process.stop()


def _push(url: str, mutations: list[dict]) -> dict:
    answer = httpx.post(f"{url}/api/v1/sync/push", json={"mutations": mutations}, headers=staff_headers(url))
    answer.raise_for_status()
    return answer.json()


def _create(kind: str, data: dict) -> dict:
    return {
        "mutation_id": new_id(),
        "kind": kind,
        "id": data.get("id") or data["encounter_id"],
        "op": "create",
        "data": data,
    }


def _mechanism(url: str, encounter_id: str) -> dict:
    answer = httpx.get(f"{url}/api/v1/encounters/{encounter_id}/mechanism", headers=staff_headers(url))
    return answer.json() if answer.status_code == 200 else {}


def test_an_injury_changed_on_the_phone_and_at_the_gateway_is_settled_by_the_nurse(gateway, browser):
    gateway.start()
    context = phone_context(browser)
    page = context.new_page()
    pair_and_sign_in(page, gateway.url, pairing_code(gateway.url))
    page.get_by_label("Given name").fill("Cora")
    page.get_by_label("Family name").fill("Conflict")
    page.get_by_role("button", name="Add patient").click()
    page.get_by_label("Mechanism").select_option("scald")
    page.get_by_role("button", name="Start encounter").click()
    page.get_by_role("heading", name="Injury").wait_for()
    encounter_id = page.url.rsplit("/", 1)[1]
    poll(page, "() => document.querySelector('#queue-status')?.textContent === 'nothing waiting'")
    assert _mechanism(gateway.url, encounter_id)["data"]["type"] == "scald"

    context.set_offline(True)
    page.locator("summary", has_text="Record or change the injury").click()
    page.get_by_label("Mechanism").select_option("contact")
    page.get_by_role("button", name="Save the injury").click()
    page.locator("#injury", has_text="waiting to send").wait_for()
    at_gateway = _mechanism(gateway.url, encounter_id)
    update = {**at_gateway["data"], "type": "flame", "enclosed_space": True}
    clinician = {"mutation_id": new_id(), "kind": "mechanism", "id": encounter_id, "op": "update"}
    assert _push(gateway.url, [{**clinician, "base_version": 1, "data": update}])["applied"] == 1

    context.set_offline(False)
    page.evaluate("window.dispatchEvent(new Event('online'))")
    poll(page, "() => document.querySelector('#queue-status')?.textContent.includes('1 to settle')")
    page.get_by_role("link", name="1 to settle").click()
    conflict = page.locator("[data-conflict]")
    conflict.wait_for()
    assert "by nurse" in conflict.inner_text()
    rows = conflict.locator("tbody tr").all_inner_texts()
    assert [row.split("\t") for row in rows] == [["kind of injury", "flame", "contact"]]  # words, not keys
    assert "Changed only at the gateway, kept either way: enclosed space: yes" in conflict.inner_text()
    shot(page, "phone-conflict", readme="app-conflict.png")

    page.get_by_role("button", name="Keep mine").click()
    poll(page, "() => document.querySelector('#queue-status')?.textContent === 'nothing waiting'")
    settled = _mechanism(gateway.url, encounter_id)
    assert (settled["meta"]["version"], settled["data"]["type"]) == (3, "contact")
    assert settled["data"]["enclosed_space"] is True  # what only the clinician changed stays
    context.close()


def test_the_change_feed_keeps_the_phone_within_its_bound_of_patients(gateway, browser):
    gateway.start()
    oldest = [{"id": new_id(), "given_name": "Old", "family_name": f"Patient {i}", "sex": "unknown"} for i in range(5)]
    old_encounter = {
        "id": new_id(),
        "patient_id": oldest[0]["id"],
        "mode": "emergency",
        "time_of_arrival": "2026-01-02T10:00:00Z",
    }
    _push(gateway.url, [_create("patient", p) for p in oldest] + [_create("encounter", old_encounter)])
    newer = [
        {"id": new_id(), "given_name": "New", "family_name": f"Patient {i}", "sex": "unknown"}
        for i in range(PATIENT_BOUND)
    ]
    assert _push(gateway.url, [_create("patient", p) for p in newer])["applied"] == PATIENT_BOUND

    context = phone_context(browser)
    page = context.new_page()
    pair_and_sign_in(page, gateway.url, pairing_code(gateway.url))
    kept = poll(
        page,
        f"async () => {{ const ids = await ({PHONE_RECORDS})('patient'); return ids.length === {PATIENT_BOUND} && ids; }}",
    )
    assert set(kept) == {p["id"] for p in newer}
    assert page.evaluate(PHONE_RECORDS, "encounter") == []
    page.reload()
    page.get_by_role("heading", name="Patients").wait_for()
    assert page.locator("ul.list li").count() == PATIENT_BOUND
    context.close()


def test_a_new_app_version_updates_the_phone_and_keeps_the_photo_waiting(gateway, browser, tmp_path):
    app = tmp_path / "app"
    shutil.copytree(APP_DIR, app)
    gateway.env["BURNEDGE_GATEWAY_PHONE_APP_DIR"] = str(app)
    gateway.start()
    context = phone_context(browser)
    page = context.new_page()
    pair_and_sign_in(page, gateway.url, pairing_code(gateway.url))
    poll(page, "async () => Boolean(navigator.serviceWorker.controller)")
    page.get_by_label("Given name").fill("Uma")
    page.get_by_label("Family name").fill("Update")
    page.get_by_role("button", name="Add patient").click()
    page.get_by_role("button", name="Start encounter").click()
    poll(page, "() => document.querySelector('#queue-status')?.textContent === 'nothing waiting'")
    gateway.stop()

    page.get_by_role("link", name="Photograph the burn").click()
    photo = noise_photo(tmp_path / "waiting.jpg", 3, size=(1200, 900), quality=95)
    page.locator("#fallback").set_input_files(str(photo))
    poll(page, "() => /1 photos waiting/.test(document.querySelector('#queue-status')?.textContent)")
    (app / "app.css").write_text((app / "app.css").read_text() + "\n.updated-by-the-test { color: inherit; }\n")
    gateway.start()

    page.goto(f"{gateway.url}/app/#/")
    page.reload()  # a navigation: the browser asks the gateway for the service worker again
    page.locator(".banner", has_text="The app was updated from the gateway").wait_for(timeout=30_000)
    stored = poll(
        page,
        f"async () => {{ const list = await ({PHONE_PHOTOS})(); return list[0]?.state === 'stored' && list; }}",
        60,
    )
    assert stored[0]["sha256"] == hashlib.sha256(photo.read_bytes()).hexdigest()
    served = page.evaluate("fetch('/app/app.css').then((r) => r.text())")
    assert ".updated-by-the-test" in served
    context.close()
