"""Server time of the clinic's pages next to the JSON API serving the same data, and first paint in Chromium.

    .venv/bin/python -m benchmarks.page_times [--requests 200] [--json out.json]

A real gateway process on loopback with one encounter whose 3D analysis has run (a rendered phantom). Same run,
same machine, one request at a time:
- the encounter page (/encounters/{id}) next to the API calls that carry its data (the record, the decision
  support, the transfers and consultations);
- the analysis result page (/analyses/{id}) next to the API's job, result and artifact list;
- first contentful paint of both pages in headless Chromium (when Playwright and Chromium are installed).
Goals (issue 19): page p95 <= 50 ms server-side, first paint <= 1 s on loopback.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import platform
import statistics
import tempfile
import time
from pathlib import Path

import httpx

from burnedge.demo_client import GatewayClient
from harness.bodies import encounter_body, patient_body
from harness.browser import browser_missing, launch
from harness.processes import GatewayProcess, add_user_cli, free_port, login
from harness.sites import wait_for
from processing.phantom.generate import run as render_phantom
from schemas.burn_chart import LundBrowderRegion
from schemas.phantom import PhantomShape, PhantomSpec


def timed(client: httpx.Client, paths: list[str], n: int) -> dict:
    """p50 and p95 (ms) of fetching every path in `paths` once, n times, after a warm-up."""
    for path in paths:
        client.get(path).raise_for_status()
    samples = []
    for _ in range(n):
        start = time.perf_counter()
        for path in paths:
            r = client.get(path)
            r.raise_for_status()
        samples.append((time.perf_counter() - start) * 1000)
    samples.sort()
    return {"p50_ms": round(statistics.median(samples), 2), "p95_ms": round(samples[int(0.95 * len(samples)) - 1], 2)}


def first_paint(url: str, token: str, paths: list[str]) -> dict[str, float]:
    from playwright.sync_api import sync_playwright

    paints = {}
    with sync_playwright() as playwright:
        browser = launch(playwright)
        context = browser.new_context()
        context.add_cookies([{"name": "burnedge_session", "value": token, "url": url}])
        page = context.new_page()
        for path in paths:
            page.goto(url + path)
            page.goto(url + path)  # the second load: scripts and styles cached, as at the desk
            fcp = None
            for _ in range(20):  # the entry is recorded just after the paint, which may follow the load event
                fcp = page.evaluate(
                    "performance.getEntriesByType('paint').filter(e => e.name === 'first-contentful-paint')"
                    ".map(e => e.startTime)[0] || null"
                )
                if fcp is not None:
                    break
                page.wait_for_timeout(100)
            paints[path] = round(fcp, 1) if fcp is not None else None
        browser.close()
    return paints


def seed(client: GatewayClient, work: Path) -> tuple[str, str]:
    """A patient, an emergency encounter with a charted burn, the phantom's photos and a finished analysis."""
    patient = patient_body()
    client.post("/api/v1/patients", patient, "patient")
    encounter = encounter_body(patient["id"])
    client.post("/api/v1/encounters", encounter, "encounter")
    chart = {
        "encounter_id": encounter["id"],
        "assessed_at": dt.datetime.now(dt.UTC).isoformat(),
        "entries": [{"region": LundBrowderRegion.trunk_anterior.value, "fraction": 0.5, "depth": "deep_partial"}],
    }
    client.http.put(
        f"/api/v1/encounters/{encounter['id']}/burn-chart", json=chart, headers={"If-None-Match": "*"}
    ).raise_for_status()
    spec = PhantomSpec(shape=PhantomShape.patch, seed=12, area_cm2=16.0, depth_mm=2.5, views=8, width=960, height=720)
    render_phantom(spec, work / "phantom")
    for photo in sorted((work / "phantom" / "images").glob("*.jpg")):
        client.upload(photo, encounter["id"])
    job = client.post(f"/api/v1/encounters/{encounter['id']}/analyses", {}, "analysis")
    wait_for(lambda: client.get(f"/api/v1/analyses/{job['id']}", "job")["state"] == "done", 600, "the analysis")
    return encounter["id"], job["id"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--requests", type=int, default=200, help="timed fetches of each page and its API calls")
    parser.add_argument("--json", help="also write the figures here")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        gw = GatewayProcess(work / "gw.sqlite3", free_port())
        gw.env["BURNEDGE_JOBS_WORKERS"] = "1"
        add_user_cli(gw.db, "bench", "clinician")
        gw.start(timeout=60)
        client = GatewayClient(gw.url)
        try:
            headers = login(client.http, "bench")
            client.http.headers.update(headers)
            encounter_id, job_id = seed(client, work)
            token = headers["Authorization"].split(" ", 1)[1]
            pages = httpx.Client(base_url=gw.url, cookies={"burnedge_session": token}, timeout=30)
            api = httpx.Client(base_url=gw.url, headers=headers, timeout=30)
            e, j = f"/api/v1/encounters/{encounter_id}", f"/api/v1/analyses/{job_id}"
            rows = {
                "encounter page": timed(pages, [f"/encounters/{encounter_id}"], args.requests),
                "encounter, JSON API": timed(
                    api,
                    [f"{e}/record", f"{e}/decision-support", f"{e}/transfers", f"{e}/consultations"],
                    args.requests,
                ),
                "result page": timed(pages, [f"/analyses/{job_id}"], args.requests),
                "result, JSON API": timed(api, [j, f"{j}/result", f"{j}/artifacts"], args.requests),
            }
            reason = browser_missing()
            paints = (
                {} if reason else first_paint(gw.url, token, [f"/encounters/{encounter_id}", f"/analyses/{job_id}"])
            )
        finally:
            client.close()
            gw.stop()
    figures = {
        "date": dt.date.today().isoformat(),
        "machine": f"{platform.machine()}, {os.cpu_count()} cores",
        "requests": args.requests,
        "server_ms": rows,
        "encounter_page_vs_api_p50": round(rows["encounter page"]["p50_ms"] / rows["encounter, JSON API"]["p50_ms"], 2),
        "result_page_vs_api_p50": round(rows["result page"]["p50_ms"] / rows["result, JSON API"]["p50_ms"], 2),
        "first_contentful_paint_ms": paints or f"not measured: {reason}",
    }
    print(f"{'':<24}{'p50 ms':>10}{'p95 ms':>10}")
    for name, row in rows.items():
        print(f"{name:<24}{row['p50_ms']:>10.2f}{row['p95_ms']:>10.2f}")
    print(
        f"page / API (p50): encounter {figures['encounter_page_vs_api_p50']}, result {figures['result_page_vs_api_p50']}"
    )
    print(f"first contentful paint (ms): {figures['first_contentful_paint_ms']}")
    if args.json:
        Path(args.json).write_text(json.dumps(figures, indent=2) + "\n")


if __name__ == "__main__":
    main()
