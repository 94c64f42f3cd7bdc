"""The clinic's and the burn center's pages in a real browser (Playwright driving Debian's Chromium) against a real
gateway process and a real center process on loopback: the clinician's flow end to end, from sign-in to the
consultant's advice back on the encounter. Screenshots of each step are saved as test artifacts
(harness/browser.py)."""

from __future__ import annotations

import datetime as dt
import re
import subprocess
import time

import pytest

from gateway.pages.encounter_view import FORM_PAGES
from harness.browser import DESKTOP, PHONE, TABLET, browser_missing, distinct_colours, shot
from harness.page_fit import fit_problems
from harness.plain_words import internal_codes
from harness.processes import PASSWORD
from harness.sites import Sites, cli
from processing.segmentation.infer import SHIPPED_MODEL, BurnSegmenter

pytestmark = pytest.mark.skipif(bool(browser_missing()), reason=browser_missing() or "browser present")

ANALYSIS_TIMEOUT_MS = 300_000


@pytest.fixture(scope="module")
def phantom(tmp_path_factory):
    from tests.phantom_helpers import render_small_patch

    return render_small_patch(tmp_path_factory.mktemp("phantom"))


@pytest.fixture(scope="module")
def sites(tmp_path_factory):
    sites = Sites(tmp_path_factory.mktemp("sites"))
    sites.gateway.env["BURNEDGE_JOBS_WORKERS"] = "1"
    sites.set_up()
    sites.center.start()
    sites.gateway.start()
    yield sites
    sites.stop()


def expect(locator):
    from playwright.sync_api import expect as playwright_expect

    return playwright_expect(locator)


def sign_in(page, url: str, username: str) -> None:
    page.goto(url + "/")
    page.wait_for_url(re.compile(r"/sign-in"))
    page.get_by_label("Username").fill(username)
    page.get_by_label("Password").fill(PASSWORD)
    page.get_by_role("button", name="Sign in").click()
    page.wait_for_load_state()


def poll(page, script: str, timeout_s: float = 30.0) -> None:
    """Wait until `script` (an expression) is true in the page. Polled from here with page.evaluate, which the
    pages' CSP allows, unlike wait_for_function's string evaluation."""
    deadline = time.monotonic() + timeout_s
    while not page.evaluate(script):
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout_s:g} s waiting for {script}")
        page.wait_for_timeout(200)


def tab(page, name: str) -> None:
    page.get_by_role("navigation", name="Encounter sections").get_by_role("link", name=name, exact=True).click()
    page.wait_for_load_state()


def save_form(page) -> None:
    page.locator("main form.panel button[type=submit]").first.click()
    page.wait_for_load_state()


def pdf_text(path) -> str:
    return subprocess.run(["pdftotext", "-layout", str(path), "-"], capture_output=True, text=True, check=True).stdout


def test_the_clinicians_flow_end_to_end_and_the_consultants_advice_back(sites, browser, phantom, tmp_path):
    # The nurse's phone: the whole flow at 390 px with touch, as the "done when" asks.
    context = browser.new_context(
        viewport={"width": PHONE[0], "height": PHONE[1]}, has_touch=True, accept_downloads=True
    )
    page = context.new_page()
    problems: list[str] = []
    page.on("console", lambda m: problems.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: problems.append(str(e)))
    clinic = sites.gateway.url

    sign_in(page, clinic, "clin")
    shot(page, "01-patients-empty")
    page.get_by_role("link", name="New patient").click()
    page.get_by_label("Given name").fill("Amina")
    page.get_by_label("Family name").fill("Diallo")
    page.get_by_label("Age estimate (years)").fill("34")
    page.get_by_label("Weight (kg)").fill("62")
    page.get_by_label("Weight source").select_option("measured")
    page.get_by_label("Medical record number").fill("MRN-1042")
    shot(page, "02-new-patient")
    page.get_by_role("button", name="Create patient").click()
    page.wait_for_url(re.compile(r"/patients/[0-9a-f-]+$"))
    patient_url = page.url

    # The burn as a wound, recorded on the patient page: its pictures and analysis are picked for it below.
    page.locator("#wounds summary").click()
    page.get_by_label("Short name").fill("chest")
    page.get_by_label("Lund-Browder regions it covers").select_option(["trunk_anterior"])
    page.get_by_label("Side").select_option("midline")
    page.get_by_role("button", name="Record the wound").click()
    page.wait_for_url(re.compile(r"/patients/[0-9a-f-]+#wound-[0-9a-f-]+$"))
    assert "Wounds (1)" in page.inner_text("#wounds")

    page.get_by_role("link", name="New encounter").click()
    injured = (dt.datetime.now() - dt.timedelta(hours=2)).strftime("%Y-%m-%dT%H:%M")
    page.get_by_label("Mode").select_option("emergency")  # never preset: the clinician chooses
    page.get_by_label("Time of injury").fill(injured)
    page.get_by_role("button", name="Open encounter").click()
    page.wait_for_url(re.compile(r"/encounters/[0-9a-f-]+$"))
    encounter_url = page.url

    tab(page, "ABCDE")
    page.get_by_label("SpO2 (%)").fill("97")
    page.get_by_label("Heart rate (/min)").fill("112")
    shot(page, "03-primary-survey")
    save_form(page)
    assert "Primary survey (ABCDE) saved" in page.inner_text("main")
    tab(page, "Secondary survey")
    page.get_by_label("Notes").fill("Isolated scald to the chest and forearm; no other injury found.")
    save_form(page)
    tab(page, "Mechanism")
    page.get_by_label("Type").select_option("scald")
    page.get_by_label("Agent").fill("boiling water")
    save_form(page)

    # The body diagram: a region tapped opens its editor in place; saving updates %TBSA and the fluids in place.
    tab(page, "Burn chart")
    page.evaluate("window.__sameDocument = true")
    page.locator('a[data-region="trunk_anterior"]').click()
    expect(page.locator("form[action$='/regions/trunk_anterior']")).to_be_visible()
    page.get_by_label("Deep partial (%)").fill("50")
    page.get_by_role("button", name="Save region").click()
    expect(page.locator("#tbsa-figure .value")).to_have_text("6.5 %")
    # 6.5 %TBSA in an adult: below the threshold, the card gives oral advice and never a formula rate.
    assert "Oral fluids" in page.inner_text("#fluid-figure") and "mL/h" not in page.inner_text("#fluid-figure")
    page.locator('a[data-region="lower_arm_right_posterior"]').click()
    expect(page.locator("form[action$='/regions/lower_arm_right_posterior']")).to_be_visible()
    page.get_by_label("Superficial partial (%)").fill("40")
    page.get_by_role("button", name="Save region").click()
    expect(page.locator("#tbsa-figure .value")).to_have_text("7.1 %")
    assert page.evaluate("window.__sameDocument") is True, "the chart reloaded the page instead of updating it"
    shot(page, "04-burn-chart")

    tab(page, "Pictures")
    photos = sorted((phantom / "images").glob("*.jpg"))
    page.get_by_label("Which wound").select_option(label="chest (open)")
    page.set_input_files("#files", [str(p) for p in photos])
    page.get_by_role("button", name="Upload").click()
    expect(page.locator(".thumbs li")).to_have_count(len(photos), timeout=120_000)
    expect(page.locator(".thumbs li .badge-ok", has_text="chest")).to_have_count(len(photos))  # sent with tus
    for thumbnail in page.locator(".thumbs img").all():  # lazy: a phone fetches each as it scrolls into view
        thumbnail.scroll_into_view_if_needed()
    poll(page, "Array.from(document.querySelectorAll('.thumbs img')).every(i => i.complete && i.naturalWidth > 0)")
    assert "ready" in page.inner_text("#readiness")
    shot(page, "05-pictures")

    page.get_by_role("link", name="Request the 3D analysis").click()
    page.get_by_role("button", name="Request the analysis").click()
    page.wait_for_url(re.compile(r"/analyses/[0-9a-f-]+$"))
    # Progress arrives live over server-sent events, in the same document (no reload until the end).
    page.evaluate("window.__live = true")
    poll(
        page,
        "window.__live === true && !!document.querySelector('#job-progress')"
        " && document.querySelector('#job-progress').value > 0",
        timeout_s=180,
    )
    progress_heading = page.inner_text("#progress-heading")  # the state in words and the step, never a code
    assert re.search(r"^[A-Z][a-z ].*…, step [1-8] of 8", progress_heading), progress_heading
    shot(page, "06-analysis-progress")
    page.wait_for_selector("#result", timeout=ANALYSIS_TIMEOUT_MS)
    assert "geometry, not burn depth" in page.inner_text("#metrics")
    assert "cm²" in page.inner_text("#metrics")
    lead = page.inner_text("#result-summary")  # the figures and how far to trust them, first, in a sentence
    assert re.search(r"Burn area \d+\.\d cm² on the 3D surface, perimeter \d+\.\d cm", lead), lead
    assert re.search(r"Confidence (high|moderate|low): .+\. Scale from the printed marker", lead), lead
    assert "ITA" not in page.inner_text("main")  # the indicators are one click away
    page.locator("#result-details summary").click()
    version = BurnSegmenter(SHIPPED_MODEL).metadata["version"]
    assert f"model {version}" in page.inner_text("main")  # which model outlined the burn, with its card
    shot(page, "07-analysis-result-loading")
    # The viewer loads its model when it scrolls into view (a phone should not fetch it otherwise).
    page.locator("model-viewer").scroll_into_view_if_needed()
    try:
        poll(page, "document.querySelector('model-viewer').loaded === true", timeout_s=90)
    except AssertionError as exc:
        raise AssertionError(f"{exc}; browser errors: {problems}") from None
    page.wait_for_timeout(500)
    viewer = page.locator("model-viewer")
    viewer.scroll_into_view_if_needed()
    viewer_png = tmp_path / "viewer.png"
    viewer.screenshot(path=str(viewer_png))
    assert distinct_colours(viewer_png) > 500, "the 3D viewer's canvas is blank"
    shot(page, "07-analysis-result", readme="page-analysis-result.png")

    page.get_by_role("link", name=re.compile("Healing track")).click()
    page.wait_for_selector("#healing figure.plot svg")
    assert "Area" in page.inner_text("#healing") and "chest" in page.inner_text("#healing h3")
    assert page.url.startswith(patient_url.split("#")[0])
    shot(page, "08-patient-healing")

    page.goto(encounter_url)
    pending = page.locator(".recommendation-list li:has(button:text('Accept'))")
    assert pending.count() >= 2, "expected at least two recommendations to act on"
    first_key = pending.nth(0).get_attribute("data-key")
    pending.nth(0).get_by_role("button", name="Accept").click()
    page.wait_for_load_state()
    assert "accepted" in page.inner_text(f".recommendation-list li[data-key='{first_key}']")
    second = page.locator(".recommendation-list li:has(button:text('Decline'))").nth(0)
    second_key = second.get_attribute("data-key")
    second.get_by_label("Reason for declining").fill("Already given in the ambulance")
    second.get_by_role("button", name="Decline").click()
    page.wait_for_load_state()
    assert "Already given in the ambulance" in page.inner_text(f".recommendation-list li[data-key='{second_key}']")
    shot(page, "09-encounter", readme="page-encounter.png")

    tab(page, "Report")
    with page.expect_download() as download:
        page.get_by_role("link", name="Download").click()
    pdf = tmp_path / "report.pdf"
    download.value.save_as(pdf)
    assert pdf.read_bytes()[:5] == b"%PDF-"
    text = pdf_text(pdf)
    assert "Diallo" in text and "7.1" in text
    assert f"segmentation model {version}" in " ".join(text.split())  # the model section names the model
    assert internal_codes(text) == [], "the report shows codes instead of clinical words"

    # Sending asks first: to whom, what goes and its size, and the patient's consent (recorded on the encounter).
    page.goto(encounter_url)
    page.get_by_role("link", name="Send to the burn center…").click()
    page.get_by_role("heading", name="Send to the burn center?").wait_for()
    assert "Test burn center" in page.inner_text("#send-recipient")
    parts = page.inner_text("#send-parts")
    assert "Photos (8)" in parts and "3D measurements" in parts and re.search(r"\d+(\.\d)? (kB|MB)", parts)
    page.get_by_role("button", name="Send now").click()  # no consent chosen: the browser asks for one
    assert page.url.endswith("/send")
    page.get_by_label("The patient agreed to the sending").check()
    shot(page, "10-send-confirmation", readme="page-send-confirmation.png")
    page.get_by_role("button", name="Send now").click()
    page.wait_for_url(re.compile(r"/encounters/[0-9a-f-]+#burn-center$"))
    for _ in range(120):
        if page.locator("[data-transfer-state='delivered']").count():
            break
        page.wait_for_timeout(500)
        page.reload()
    assert page.locator("[data-transfer-state='delivered']").count() == 1
    shot(page, "10-sent")

    # The consultant at the burn center: the case, its report, advice written and delivered back.
    center = browser.new_context(viewport={"width": DESKTOP[0], "height": DESKTOP[1]})
    consultant = center.new_page()
    consultant.on("pageerror", lambda e: problems.append(str(e)))
    sign_in(consultant, sites.center.url, "consult")
    expect(consultant.locator("h1")).to_have_text("Incoming cases")
    shot(consultant, "12-center-cases")
    consultant.get_by_role("link", name="Amina Diallo").first.click()  # cases are listed by the patient's name
    consultant.wait_for_load_state()
    expect(consultant.locator("#tbsa-figure .value")).to_have_text("7.1 %")
    assert internal_codes(consultant.inner_text("body")) == [], "the center's case shows codes"
    assert "geometry, not burn depth" in consultant.inner_text("#metrics")
    report_href = consultant.get_by_role("link", name=re.compile("report")).get_attribute("href")
    report = center.request.get(sites.center.url + report_href)
    assert report.ok and report.body()[:5] == b"%PDF-"
    consultant.locator("model-viewer").scroll_into_view_if_needed()
    poll(consultant, "document.querySelector('model-viewer').loaded === true", timeout_s=90)
    shot(consultant, "13-center-case")
    consultant.get_by_label("Recommendation").select_option("manage_locally")
    consultant.get_by_role("textbox", name="Advice").fill(
        "Manage locally: dress with silver sulfadiazine, review the wound in 48 h."
    )
    consultant.get_by_role("button", name="Send advice").click()
    consultant.wait_for_load_state()
    assert "Advice written" in consultant.inner_text("main")
    for _ in range(120):
        if consultant.locator("[data-note-state='delivered']").count():
            break
        consultant.wait_for_timeout(500)
        consultant.reload()
    assert consultant.locator("[data-note-state='delivered']").count() == 1
    shot(consultant, "14-center-advice-delivered")

    # The center's administrator runs the box but reads no case: the case page answers as the API does.
    case_url = consultant.url.split("?")[0]
    cli(
        "users",
        "add",
        "--center",
        "--username",
        "it",
        "--role",
        "admin",
        "--password-stdin",
        env=sites.center.env,
        stdin=PASSWORD + "\n",
    )
    admin = browser.new_context()
    admin_page = admin.new_page()
    sign_in(admin_page, sites.center.url, "it")
    assert admin_page.url.endswith("/admin")
    refused = admin_page.goto(case_url)
    assert refused.status == 403 and "Not allowed" in admin_page.inner_text("main")
    assert admin.request.get(case_url.replace("/cases/", "/api/v1/cases/")).status == 403
    admin.close()

    # At the clinic the advice is counted in the header and on the patient list until someone opens it.
    page.goto(clinic + "/patients")
    for _ in range(120):
        if page.locator("#header-notice").count():
            break
        page.wait_for_timeout(500)
        page.reload()
    expect(page.locator("#header-notice")).to_contain_text("New advice 1")
    expect(page.locator("#new-advice")).to_contain_text("Amina Diallo")
    expect(page.locator("tr:has-text('Amina Diallo') [data-new-advice]")).to_have_text("1 new advice")
    shot(page, "15-new-advice-on-the-list")
    page.locator("#new-advice a", has_text="Amina Diallo").click()
    expect(page.locator("#burn-center .advice-text")).to_contain_text("review the wound in 48 h")
    expect(page.locator("#burn-center [data-new-advice]")).to_have_count(1)
    assert "1 new: manage locally" in page.inner_text("#encounter-summary")
    shot(page, "15-advice-at-the-clinic")
    page.goto(clinic + "/patients")
    assert page.locator("#header-notice").count() == 0 and page.locator("[data-new-advice]").count() == 0
    center.close()

    # A full-thickness burn of the forearm as well: the referral becomes urgent, and the summary leads with it.
    page.goto(encounter_url)
    tab(page, "Burn chart")
    page.locator('a[data-region="lower_arm_left_anterior"]').click()
    page.get_by_label("Full thickness (%)").fill("30")
    page.get_by_role("button", name="Save region").click()
    expect(page.locator("#tbsa-figure .value")).not_to_have_text("7.1 %")

    # Phone, tablet and desktop: every page fits the screen's width (no sideways scrolling, no word broken in a
    # table cell) and speaks clinical words; on a phone the urgent recommendations are in the first screen.
    pages = {"encounter": encounter_url, "burn-chart": encounter_url + "/burn-chart?region=trunk_anterior"}
    pages |= {"pictures": encounter_url + "/pictures", "analyses": encounter_url + "/analyses"}
    pages |= {slug: f"{encounter_url}/parts/{slug}" for slug in FORM_PAGES}
    pages |= {"patients": clinic + "/patients", "patient": patient_url, "burn-center": clinic + "/transfers"}
    pages |= {"patient-edit": patient_url + "/edit", "patient-merge": patient_url + "/merge?q=Diallo"}
    page.goto(encounter_url)
    pages["analysis"] = clinic + page.locator(".summary-facts a[href^='/analyses/']").get_attribute("href")
    misfits: dict[str, list[str]] = {}
    for width, height in (PHONE, TABLET, DESKTOP):
        page.set_viewport_size({"width": width, "height": height})
        for name, url in pages.items():
            page.goto(url)
            shot(page, f"11-{name}-{width}")
            assert internal_codes(page.inner_text("body")) == [], f"{name} shows codes instead of clinical words"
            if problems_here := fit_problems(page):
                misfits[f"{name} at {width} px"] = problems_here
        page.goto(encounter_url)
        urgent = page.locator("#summary-urgent li")
        assert urgent.count() == page.locator(".recommendation-list li.urgent:has(button:text('Accept'))").count()
        assert urgent.count() >= 1 and "Referral" in urgent.first.inner_text()
        last = urgent.last.bounding_box()
        assert last["y"] + last["height"] <= height, f"the urgent recommendations start below a {width} px screen"
        phone_image = "page-encounter-phone.png" if width == PHONE[0] else None
        shot(page, f"12-encounter-first-screen-{width}", full_page=False, readme=phone_image)
    # Lists grow with "Add another", not as numbered empty rows.
    page.goto(encounter_url + "/parts/intake")
    medications = page.locator("#field-medications")
    assert medications.locator(":scope > fieldset.field-list-row:visible").count() == 1
    assert medications.locator("legend").nth(1).inner_text() == "Medication 1"
    medications.get_by_role("button", name="Add another medication").click()
    assert medications.locator(":scope > fieldset.field-list-row:visible").count() == 2
    assert not misfits, "pages that do not fit their screen:\n" + "\n".join(f"{k}: {v}" for k, v in misfits.items())
    page.set_viewport_size({"width": DESKTOP[0], "height": DESKTOP[1]})
    assert not problems, f"the browser reported errors: {problems}"
    context.close()


def test_markup_is_text_forged_writes_are_refused_and_roles_see_what_they_may_do(sites, browser):
    from harness.processes import add_user_cli

    add_user_cli(sites.gateway.db, "nina", "nurse")
    context = browser.new_context(viewport={"width": TABLET[0], "height": TABLET[1]})
    page = context.new_page()
    dialogs: list[str] = []
    page.on("dialog", lambda d: (dialogs.append(d.message), d.dismiss()))
    clinic = sites.gateway.url

    sign_in(page, clinic, "nina")
    page.get_by_role("link", name="New patient").click()
    page.get_by_label("Given name").fill("<script>alert(1)</script>")
    page.get_by_label("Family name").fill('<img src=x onerror="alert(2)">')
    page.get_by_role("button", name="Create patient").click()
    page.wait_for_url(re.compile(r"/patients/[0-9a-f-]+$"))
    assert "<script>alert(1)</script>" in page.inner_text("h1")
    page.goto(clinic + "/patients?q=script")
    assert "<script>alert(1)</script>" in page.inner_text("table")
    shot(page, "20-markup-as-text")

    # A write without the page's token (what a forged cross-site form amounts to) is refused and stores nothing.
    status = page.evaluate(
        "fetch('/patients/new', {method: 'POST', headers: {'Content-Type': 'application/x-www-form-urlencoded'},"
        " body: 'id=0190c0de-0000-7000-8000-000000000042&given_name=Forged'}).then(r => r.status)"
    )
    assert status == 403
    page.goto(clinic + "/patients?q=Forged")
    assert "No patient matches" in page.inner_text("main section.panel")

    # A nurse reads the chart but does not chart (a clinician's assessment), and acts on no recommendation.
    page.goto(clinic + "/patients?q=script")
    page.locator("table a").first.click()
    page.get_by_role("link", name="New encounter").click()
    page.get_by_label("Mode").select_option("consultation")
    page.get_by_role("button", name="Open encounter").click()
    page.wait_for_url(re.compile(r"/encounters/[0-9a-f-]+$"))
    tab(page, "Burn chart")
    # With the keyboard: a region is a link; Enter opens it.
    page.locator('a[data-region="trunk_anterior"]').focus()
    page.keyboard.press("Enter")
    expect(page.locator("#chart-area")).to_contain_text("a clinician charts the burn")
    assert page.locator("form.region-editor").count() == 0
    page.goto(page.url.split("/burn-chart")[0])
    assert page.get_by_role("button", name="Accept").count() == 0
    assert page.get_by_role("link", name="Send to the burn center…").count() == 0
    page.goto(clinic + "/admin")
    assert "Not allowed" in page.inner_text("main") or "403" in page.inner_text("main")
    shot(page, "21-nurse-admin-refused")
    assert not dialogs, f"a script ran: {dialogs}"
    context.close()
