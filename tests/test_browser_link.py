"""Linking a clinic to a burn center through the two administrators' pages, in a real browser (Playwright driving
Debian's Chromium) against a real gateway process and a real center process on loopback, with no console and no
restart: the clinic's keys file goes to the center, the center's QR code (a screenshot of it, as a phone's photo
would) to the clinic, both fingerprints compared, the link switched on. Then a case goes to the center and the
consultant's advice comes back to the clinic's header."""

from __future__ import annotations

import re

import pytest

from harness.bodies import encounter_body, patient_body
from harness.browser import DESKTOP, PHONE, browser_missing, shot
from harness.page_fit import fit_problems
from harness.processes import PASSWORD, GatewayProcess, add_user_cli, free_port
from harness.sites import CenterProcess, cli, noise_photo, wait_for

pytestmark = pytest.mark.skipif(bool(browser_missing()), reason=browser_missing() or "browser present")


@pytest.fixture(scope="module")
def unlinked(tmp_path_factory):
    """A clinic and a burn center, both running, neither knowing the other."""
    folder = tmp_path_factory.mktemp("unlinked")
    center = CenterProcess(folder, free_port(), free_port())
    gateway = GatewayProcess(folder / "clinic.sqlite3", free_port())
    gateway.env.update(
        {
            "BURNEDGE_SYNC_INTERVAL_S": "0.5",
            "BURNEDGE_SYNC_RETRY_BASE_S": "0.2",
            "BURNEDGE_SYNC_RETRY_MAX_S": "1",
            "BURNEDGE_SYNC_CONNECT_TIMEOUT_S": "2",
            "BURNEDGE_JOBS_WORKERS": "0",
        }
    )
    add_user_cli(gateway.db, "ada", "admin")
    add_user_cli(gateway.db, "clin", "clinician")
    for username, role in (("it", "admin"), ("consult", "consultant")):
        cli("users", "add", "--center", "--username", username, "--role", role, "--name", username,
            "--password-stdin", env=center.env, stdin=PASSWORD + "\n")  # fmt: skip
    center.start()
    gateway.start()
    yield gateway, center
    gateway.stop()
    center.stop()


def sign_in(page, url: str, username: str, then: str) -> None:
    page.goto(url + then)
    page.get_by_label("Username").fill(username)
    page.get_by_label("Password").fill(PASSWORD)
    page.get_by_role("button", name="Sign in").click()
    page.wait_for_load_state()


def fingerprint_in(page, selector: str) -> str:
    return " ".join(page.inner_text(selector).split())


def test_two_administrators_link_the_sites_on_their_pages_and_a_case_and_advice_cross(unlinked, browser, tmp_path):
    gateway, center = unlinked
    problems: list[str] = []
    clinic = browser.new_context(
        viewport={"width": PHONE[0], "height": PHONE[1]}, has_touch=True, accept_downloads=True
    )
    it = browser.new_context(viewport={"width": DESKTOP[0], "height": DESKTOP[1]}, accept_downloads=True)
    ada, center_admin = clinic.new_page(), it.new_page()
    for page in (ada, center_admin):
        page.on("pageerror", lambda e: problems.append(str(e)))

    # 1. The clinic's administrator, on a phone, makes the clinic's keys.
    sign_in(ada, gateway.url, "ada", "/transfers")
    assert "This clinic does not send cases" in ada.inner_text("#link")
    ada.get_by_label("The clinic's name, as the burn center will see it").fill("Kasese field clinic")
    ada.get_by_label("Site id").fill("clinic-kasese")
    ada.get_by_role("button", name="Make this clinic's keys").click()
    ada.wait_for_load_state()
    assert "keys were made" in ada.inner_text("main")
    clinic_print = fingerprint_in(ada, "#step-keys .fingerprint-groups")
    assert re.fullmatch(r"([0-9A-F]{4} ){15}[0-9A-F]{4}", clinic_print)
    assert fit_problems(ada) == []
    shot(ada, "link-01-clinic-keys", readme="page-link-clinic.png")
    with ada.expect_download() as download:
        ada.get_by_role("link", name="Download the keys file").click()
    keys_file = tmp_path / "clinic-kasese.pub.json"
    download.value.save_as(keys_file)

    # 2. The center's administrator enrols the clinic from its file, once the fingerprints match.
    sign_in(center_admin, center.url, "it", "/clinics")
    center_admin.get_by_label("The clinic's keys file, or a photo of its QR code").set_input_files(keys_file)
    center_admin.get_by_role("button", name="Read the keys").click()
    center_admin.wait_for_load_state()
    assert fingerprint_in(center_admin, ".confirm-card .fingerprint-groups") == clinic_print
    center_admin.get_by_role("button", name="Enrol the clinic's keys").click()  # not ticked: refused, said why
    center_admin.wait_for_load_state()
    assert "compare the fingerprint" in center_admin.inner_text(".confirm-card")
    center_admin.get_by_label(re.compile("I compared the fingerprint")).check()
    shot(center_admin, "link-02-center-checks-clinic")
    center_admin.get_by_role("button", name="Enrol the clinic's keys").click()
    center_admin.wait_for_load_state()
    assert "The clinic was enrolled" in center_admin.inner_text("main")
    assert "Kasese field clinic" in center_admin.inner_text("#enrolled")
    shot(center_admin, "link-03-center-clinics", readme="page-link-center.png")

    # 3. The clinic photographs the center's QR code (here: a screenshot of it) and enrols the center.
    center_print = fingerprint_in(center_admin, "#center-keys .fingerprint-groups")
    endpoint = center_admin.inner_text("#center-keys code.endpoint")
    qr = tmp_path / "center-qr.png"
    center_admin.locator("#center-keys svg").screenshot(path=str(qr))
    ada.get_by_label("The burn center's keys file, or a photo of its QR code").set_input_files(qr)
    ada.get_by_role("button", name="Read the keys").click()
    ada.wait_for_load_state()
    assert fingerprint_in(ada, ".confirm-card .fingerprint-groups") == center_print
    assert "Test burn center" in ada.inner_text(".confirm-card")
    ada.get_by_label(re.compile("I compared the fingerprint")).check()
    ada.get_by_role("button", name="Enrol the burn center's keys").click()
    ada.wait_for_load_state()
    assert "The burn center's keys were enrolled" in ada.inner_text("main")

    # 4. The link switched on with the address the center's page shows: the gateway reaches it, no restart.
    ada.get_by_label("The burn center's address").fill(endpoint)
    ada.get_by_label("Send cases and fetch the burn center's advice").check()
    ada.get_by_role("button", name="Save the link").click()
    ada.wait_for_load_state()
    assert "The link is on" in ada.inner_text("main")
    for _ in range(60):
        if ada.inner_text("#last-contact") != "—":
            break
        ada.wait_for_timeout(500)
        ada.reload()
    facts = ada.inner_text("#link")
    assert "center-test" in facts and "Last problem" not in facts, facts
    assert fit_problems(ada) == []
    shot(ada, "link-04-clinic-linked")

    # 5. A case goes to the center and the consultant's advice comes back to the clinic.
    from burnedge.demo_client import GatewayClient

    api = GatewayClient(gateway.url)
    api.login("clin", PASSWORD)
    patient = api.post("/api/v1/patients", patient_body(), "patient")
    encounter_id = api.post("/api/v1/encounters", encounter_body(patient["meta"]["id"]), "encounter")["meta"]["id"]
    api.upload(noise_photo(tmp_path / "photo.jpg", 1, size=(800, 600)), encounter_id)
    nurse = clinic.new_page()
    nurse.context.clear_cookies()
    sign_in(nurse, gateway.url, "clin", f"/encounters/{encounter_id}/send")
    assert "Recorded" in nurse.inner_text("#send-consent")  # the API recorded it with the encounter
    nurse.get_by_role("button", name="Send now").click()
    nurse.wait_for_url(re.compile(r"#burn-center$"))
    cases = wait_for(lambda: center.rows("SELECT site_id, bundle_id FROM bundles"), 60, "the case at the center")
    consultant = center.client()
    site_id, bundle_id = cases[0]
    assert site_id == "clinic-kasese"
    consultant.post(
        f"/api/v1/cases/{site_id}/{bundle_id}/notes",
        {"recommendation": "manage_locally", "advice": "Manage locally; review in 48 h."},
        "advice",
    )
    for _ in range(60):
        nurse.goto(gateway.url + "/patients")
        if nurse.locator("#header-notice").count():
            break
        nurse.wait_for_timeout(500)
    assert nurse.locator("#header-notice").count() == 1
    assert problems == []
