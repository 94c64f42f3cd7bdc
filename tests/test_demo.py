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
    shin = next(line for line in out.splitlines() if line.strip().startswith("left shin"))
    assert "1 measured visit," in shin and "beside the chart's" in shin
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
    _check_fhir(out, db, tmp_path)
    _check_patient_page(out, db)
    again = subprocess.run(args, capture_output=True, text=True, cwd=REPO, env=env, timeout=300)
    assert again.returncode == 0, again.stderr[-4000:]  # a second run reuses the series, visits and analyses
    assert "Healing trend:" in again.stdout


def _check_fhir(out: str, db, tmp_path) -> None:
    """The day-0 encounter as a FHIR Bundle, fetched from a real gateway and written by the CLI: every resource
    valid, one WoundSize per measured visit with the stored figures, each file it names served as described."""
    import base64
    import hashlib

    import httpx

    pytest.importorskip("fhir.resources", reason="the FHIR export needs fhir.resources (pyproject)")
    from processing.fhir.bundle import model_of

    lines = out.splitlines()
    password = next(line for line in lines if line.startswith("Open the patient's page")).rsplit("password ", 1)[1]
    report_line = next(line for line in lines if line.startswith("The clinical report of the day-0 visit"))
    encounter_id = report_line.split("/api/v1/encounters/")[1].split("/")[0]
    gateway = GatewayProcess(db, free_port())
    gateway.env["BURNEDGE_JOBS_WORKERS"] = "0"
    gateway.start(timeout=60)
    try:
        with httpx.Client(base_url=gateway.url, timeout=120) as http:
            login = {"username": "clinician", "password": password.rstrip("):")}
            token = http.post("/api/v1/auth/login", json=login).json()["access_token"]
            headers = {"Authorization": f"Bearer {token}"}
            r = http.get(f"/api/v1/encounters/{encounter_id}/fhir", headers=headers)
            assert r.status_code == 200 and r.headers["content-type"].startswith("application/fhir+json")
            bundle = r.json()
            model_of("Bundle").model_validate(bundle)
            resources = [e["resource"] for e in bundle["entry"]]
            for resource in resources:
                model_of(resource["resourceType"]).model_validate(resource)
            sizes = [
                x
                for x in resources
                if x["resourceType"] == "Observation" and x["code"]["coding"][0]["code"] == "72287-6"
            ]
            assert len(sizes) == 5  # the forearm's four measured visits and the shin's one
            wounds = {f"urn:uuid:{x['id']}": x for x in resources if x["resourceType"] == "Condition"}
            focus = sorted(wounds[x["focus"][0]["reference"]]["code"]["text"] for x in sizes)
            assert focus == ["Burn: left shin (left)"] + ["Burn: right forearm (right)"] * 4
            for panel in sizes:
                job_id = panel["identifier"][0]["value"].split("/v")[0]
                stored = http.get(f"/api/v1/analyses/{job_id}/result", headers=headers).json()["metrics"]
                by_code = {c["code"]["coding"][0]["code"]: c["valueQuantity"] for c in panel["component"]}
                assert by_code["89260-4"] == {
                    **by_code["89260-4"],
                    "value": round(stored["area_cm2"], 2),
                    "code": "cm2",
                }
                assert by_code["39127-6"]["value"] == round(stored["relief_max_mm"] / 10, 3)
                assert by_code["woundvolume"]["value"] == round(stored["volume_cm3"], 3)
                assert "not a burn depth" in " ".join(n["text"] for n in panel["note"])
                assert (
                    "geometry"
                    in next(c for c in panel["component"] if c["code"]["coding"][0]["code"] == "39127-6")["code"][
                        "text"
                    ].lower()
                )
                ids = {f"urn:uuid:{x['id']}" for x in resources}
                assert panel["derivedFrom"] and all(d["reference"] in ids for d in panel["derivedFrom"])
            assert sum(x["status"] == "preliminary" for x in sizes) == 2  # day 0 (both wounds), 3 h after the injury
            files = [x["content"] for x in resources if x["resourceType"] == "Media"]
            files += [x["content"][0]["attachment"] for x in resources if x["resourceType"] == "DocumentReference"]
            for attachment in files[:1] + files[-2:]:  # a photo, the painted surface, the report
                data = http.get(attachment["url"], headers=headers).content
                assert len(data) == attachment["size"]
                assert (
                    base64.b64encode(hashlib.sha1(data, usedforsecurity=False).digest()).decode() == attachment["hash"]
                )
    finally:
        gateway.stop()
    written = tmp_path / "day0.fhir.json"
    cli = [sys.executable, "-m", "burnedge.cli", "--db", str(db), "export", "fhir", encounter_id, "--out", str(written)]
    run = subprocess.run(cli, capture_output=True, text=True, cwd=REPO, env=FAST_HASH_ENV, timeout=300)
    assert run.returncode == 0, run.stderr[-3000:]
    exported = model_of("Bundle").model_validate_json(written.read_text())
    assert len(exported.entry) == len(bundle["entry"])


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
            assert page.locator("#healing h3[id^=wound-heading]").all_inner_texts() == [
                "right forearm (Right forearm, back)",
                "left shin (Left lower leg, front)",
            ]
            page.locator("model-viewer").first.scroll_into_view_if_needed()
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
