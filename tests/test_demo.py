"""The README's main command, `burnedge demo`, on a small series: everything through the real gateway."""

from __future__ import annotations

import json
import subprocess
import sys
import time

import pytest

from harness.browser import browser_missing, launch, shot
from harness.processes import FAST_HASH_ENV, REPO, GatewayProcess, free_port
from harness.report_pages import inked_share, page_texts, rasterise
from processing.report.figures import figure


def test_the_demo_uploads_analyses_and_aligns_four_visits_then_exits(tmp_path):
    db = tmp_path / "demo.sqlite3"
    args = [
        sys.executable,
        "-m",
        "burnedge.cli",
        "--db",
        str(db),
        "demo",
        "--exit",
        "--port",
        str(free_port()),
        "--views",
        "6",
        "--size",
        "960x720",
        "--clinician-masks",
        "--phantoms",
        str(tmp_path / "phantoms"),
    ]
    env = {**FAST_HASH_ENV, "PATH": "", "BURNEDGE_JOBS_POLL_S": "0.3", "BURNEDGE_JOBS_NICE": "0"}
    run = subprocess.run(args, capture_output=True, text=True, cwd=REPO, env=env, timeout=900)
    assert run.returncode == 0, run.stderr[-4000:]
    out = run.stdout
    assert "%TBSA" in out and "Healing trend:" in out and "Decision support only" in out
    # One story: the charted burn is the rendered forearm burn (about 18 cm2 of 1.85 m2), photographed 3 h after the
    # injury (provisional) though analysed three weeks later.
    assert "(Lund-Browder, superficial excluded): 0.1 %" in out and "formal resuscitation not indicated" in out
    assert next(line for line in out.splitlines() if line.startswith("day 0 ")).count("yes (3 h)") == 1
    for day in (0, 7, 14, 21):
        assert f"day {day}" in out
        assert f"day {day:>2} [" in run.stderr  # a progress bar per visit
    track_line = next(line for line in out.splitlines() if line.startswith("Healing track: "))
    track = json.loads(open(track_line.split()[2]).read())
    truth = json.loads((tmp_path / "phantoms" / "ground_truth.json").read_text())
    # Days since the injury, 3 h before the first visit.
    assert [s["day"] for s in track["sessions"]] == pytest.approx([0.125, 7.125, 14.125, 21.125], abs=0.01)
    for session, true in zip(track["sessions"], truth["sessions"], strict=True):
        true_change = 100 * (true["area_ratio_vs_day0"] - 1)
        assert session["area_change_percent"] == pytest.approx(true_change, abs=3.0), session
    assert track["healing_rate_cm2_per_day"] > 0
    _check_report(out, track, tmp_path)
    _check_patient_page(out, db)
    again = subprocess.run(args, capture_output=True, text=True, cwd=REPO, env=env, timeout=300)
    assert again.returncode == 0, again.stderr[-4000:]  # a second run reuses the series, visits and analyses
    assert "Healing trend:" in again.stdout


def _check_patient_page(out: str, db) -> None:
    """The page the demo ends on, opened as a newcomer would: four visits, the 3D burn and the healing plots."""
    lines = out.splitlines()
    at = next(i for i, line in enumerate(lines) if line.startswith("Open the patient's page"))
    password = lines[at].rsplit("password ", 1)[1].rstrip("):")
    path = "/" + lines[at + 1].strip().split("/", 3)[3]
    assert path.startswith("/patients/")
    if browser_missing():
        return
    from playwright.sync_api import sync_playwright

    gateway = GatewayProcess(db, free_port())
    gateway.env["BURNEDGE_JOBS_WORKERS"] = "0"
    gateway.start(timeout=60)
    try:
        with sync_playwright() as playwright:
            browser = launch(playwright)
            page = browser.new_page(viewport={"width": 1280, "height": 900})
            page.goto(gateway.url + path)
            page.get_by_label("Username").fill("clinician")
            page.get_by_label("Password").fill(password)
            page.get_by_role("button", name="Sign in").click()
            page.wait_for_url(gateway.url + path)
            assert page.locator("section[aria-labelledby=encounters-heading] tbody tr").count() == 4
            assert page.locator("#healing figure.plot svg").count() >= 3
            page.locator("model-viewer").scroll_into_view_if_needed()
            deadline = time.monotonic() + 90
            while not page.evaluate("document.querySelector('model-viewer').loaded === true"):
                assert time.monotonic() < deadline, "the demo's 3D burn did not load"
                page.wait_for_timeout(250)
            shot(page, "demo-patient", readme="page-patient.png")
            browser.close()
    finally:
        gateway.stop()


def _check_report(out: str, track: dict, tmp_path) -> None:
    """The report the demo wrote: every page inked, every visit's figures as stored, to the report's rounding."""
    line = next(line for line in out.splitlines() if line.startswith("The clinical report"))
    pdf = open(line.split(": ", 1)[1].split()[0], "rb").read()
    texts = page_texts(pdf)
    text = " ".join(" ".join(texts).split())
    pages = rasterise(pdf, tmp_path / "report-pages")
    if pages:
        assert len(pages) == len(texts) and all(inked_share(p) > 0.01 for p in pages)
    assert f"of {len(texts)}" in text and "Decision support only — confirmed by a clinician" in text
    for session in track["sessions"]:
        for kind in ("area_cm2", "relief_max_mm", "volume_cm3"):
            assert figure(session[kind], kind) in text, (kind, session[kind])
    assert figure(track["healing_rate_cm2_per_day"], "healing_rate_cm2_per_day", "cm²/day") in text
    assert f"day {figure(track['projected_closure_day'], 'closure_day', '')}" in text
    assert "Surface relief is geometry" in text and "PROVISIONAL" in text and "Tetanus" in text
