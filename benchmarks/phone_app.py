"""The phone app's budgets, in Debian's Chromium standing in for a phone against a real gateway on loopback:

    .venv/bin/python -m benchmarks.phone_app [--runs 5] [--photos 60]

- shell: the bytes the service worker keeps on first load (every app file and vendored script), as served and
  gzip-compressed, beside the same measure for the gateway's sign-in page (the baseline);
- offline start: a new page of the installed app, opened offline, to its patients list, beside the same start
  online (the baseline);
- check: the on-device quality check's time per preview frame (the fake camera plays a rendered phantom's orbit),
  with the CPU unthrottled (the baseline) and throttled 4x through CDP;
- verdicts: `--shots` photos taken with the in-app shutter, each with the phone's verdict, then the gateway's on the
  uploaded photo: how often the two agree (accepted or not, and the same reasons), and on which reasons they differ;
- queue: `--photos` photos of about 4 MB each, queued offline through the file input, all found byte for byte in
  IndexedDB afterwards, beside writing the same bytes to a file (the baseline).
"""

from __future__ import annotations

import argparse
import datetime as dt
import gzip
import hashlib
import json
import platform
import re
import statistics
import tempfile
import time
from pathlib import Path

import httpx

from gateway.phones.app_routes import APP_PATH, shell_paths
from harness.browser import CHROMIUM, CHROMIUM_ARGS
from harness.phone_app import (
    PHONE_PHOTOS,
    camera_args,
    fake_camera,
    gateway_with_staff,
    pair_and_sign_in,
    pairing_code,
    phone_context,
    phone_photos,
    poll,
)
from harness.sites import noise_photo

SHELL_BUDGET_KB = 500
START_BUDGET_S = 1.0
CHECK_BUDGET_MS = 50.0


def _sizes(url: str, paths: list[str]) -> tuple[int, int]:
    """(bytes as served, bytes gzip-compressed at level 6) over `paths`."""
    served = compressed = 0
    with httpx.Client(base_url=url) as client:
        for path in paths:
            body = client.get(path).content
            served += len(body)
            compressed += len(gzip.compress(body, 6))
    return served, compressed


def _page_resources(url: str, path: str) -> list[str]:
    page = httpx.get(url + path).text
    return [path, *re.findall(r'(?:src|href)="(/static/[^"]+)"', page)]


def shell(url: str) -> dict:
    app_paths = [f"{APP_PATH}/", *shell_paths()]
    app = _sizes(url, app_paths)
    pages = _sizes(url, _page_resources(url, "/sign-in"))
    return {"app_served": app[0], "app_gzip": app[1], "pages_served": pages[0], "pages_gzip": pages[1]}


def starts(context, url: str, runs: int) -> dict:
    """Seconds from navigation to the patients list: online, then offline from the service worker."""
    out = {}
    for label, offline in (("online", False), ("offline", True)):
        context.set_offline(offline)
        times = []
        for _ in range(runs):
            page = context.new_page()
            t0 = time.perf_counter()
            page.goto(f"{url}/app/")
            page.get_by_role("heading", name="Patients").wait_for()
            times.append(time.perf_counter() - t0)
            page.close()
        out[label] = times
    context.set_offline(False)
    return out


def checks(page, samples: int) -> dict:
    """The check's milliseconds per preview frame, unthrottled then with the CPU throttled 4x."""
    cdp = page.context.new_cdp_session(page)
    out = {}
    for rate in (1, 4):
        cdp.send("Emulation.setCPUThrottlingRate", {"rate": rate})
        page.wait_for_timeout(1500)
        values, phases = [], []
        while len(values) < samples:
            ms, parts = page.evaluate(
                "[document.getElementById('check').dataset.ms, document.getElementById('check').dataset.phases]"
            )
            if ms:
                values.append(float(ms))
                phases.append(json.loads(parts))
            page.wait_for_timeout(400 * rate)
        out[rate] = (
            values,
            {k: (statistics.median(p[k] for p in phases), p95([p[k] for p in phases])) for k in phases[0]},
        )
    cdp.send("Emulation.setCPUThrottlingRate", {"rate": 1})
    return out


def verdicts(page, shots: int) -> dict:
    """Photos from the shutter (taken anyway when the checks warn), uploaded; the phone's verdict beside the gateway's."""
    for _ in range(shots):
        page.get_by_role("button", name="Take photo").click()
        anyway = page.get_by_role("button", name="Take it anyway")
        if anyway.is_visible():
            anyway.click()
        page.wait_for_timeout(700)  # the orbit moves on to another view
    page.evaluate("window.dispatchEvent(new Event('burnedge-change'))")
    poll(page, f"async () => (await ({PHONE_PHOTOS})()).filter((p) => p.state === 'stored').length >= {shots}", 120)
    judged = [p for p in phone_photos(page) if p["device_verdict"] and p["asset"]]
    differing: dict[str, int] = {}
    same_reasons = 0
    for photo in judged:
        phone, gateway = set(photo["device_verdict"]["reasons"]), set(photo["asset"]["verdict"]["reasons"])
        same_reasons += phone == gateway
        for reason in phone ^ gateway:
            side = "phone only" if reason in phone else "gateway only"
            differing[f"{reason} ({side})"] = differing.get(f"{reason} ({side})", 0) + 1
    return {
        "photos": len(judged),
        "accepted_agree": sum(not p["disagrees"] for p in judged),
        "same_reasons": same_reasons,
        "differing": differing,
    }


def queue(page, folder: Path, count: int) -> dict:
    files = [noise_photo(folder / f"q{i}.jpg", 100 + i, size=(2200, 1650), quality=98) for i in range(count)]
    page.context.set_offline(True)
    before = len(phone_photos(page))
    t0 = time.perf_counter()
    for start in range(0, count, 10):
        page.locator("#fallback").set_input_files([str(f) for f in files[start : start + 10]])
        done = before + min(start + 10, count)
        poll(page, f"document.getElementById('taken').textContent.startsWith('{done} photos')", 120)
    seconds = time.perf_counter() - t0
    kept = {p["sha256"] for p in phone_photos(page)}
    sent = {hashlib.sha256(f.read_bytes()).hexdigest() for f in files}
    t1 = time.perf_counter()
    with open(folder / "baseline.bin", "wb") as out:
        for f in files:
            out.write(f.read_bytes())
    baseline = time.perf_counter() - t1
    return {
        "photos": count,
        "mb": sum(f.stat().st_size for f in files) / 1e6,
        "seconds": seconds,
        "all_kept": sent <= kept,
        "baseline_s": baseline,
    }


def p95(values: list[float]) -> float:
    return sorted(values)[max(0, round(0.95 * len(values)) - 1)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--photos", type=int, default=60)
    parser.add_argument("--shots", type=int, default=12)
    args = parser.parse_args()
    from playwright.sync_api import sync_playwright

    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        gateway = gateway_with_staff(folder)
        gateway.start()
        try:
            sizes = shell(gateway.url)
            video = fake_camera(folder)
            with sync_playwright() as playwright:
                browser = playwright.chromium.launch(
                    executable_path=str(CHROMIUM), args=[*CHROMIUM_ARGS, *camera_args(video)]
                )
                context = phone_context(browser, permissions=["camera"])
                page = context.new_page()
                pair_and_sign_in(page, gateway.url, pairing_code(gateway.url))
                poll(page, "navigator.serviceWorker.ready.then(() => navigator.serviceWorker.controller !== null)")
                start = starts(context, gateway.url, args.runs)
                page.get_by_label("Given name").fill("Bench")
                page.get_by_label("Family name").fill("Mark")
                page.get_by_role("button", name="Add patient").click()
                page.get_by_role("button", name="Start encounter").click()
                page.get_by_role("link", name="Photograph the burn").click()
                poll(page, "document.getElementById('check')?.dataset.ms !== undefined", 60)
                check = checks(page, 30)
                agreement = verdicts(page, args.shots)
                queued = queue(page, folder, args.photos)
                browser.close()
        finally:
            gateway.stop()
    print(f"# phone app budgets, {dt.date.today()}, {platform.machine()}, {platform.python_version()}")
    print(
        f"shell: {sizes['app_gzip'] / 1024:.0f} kB gzip ({sizes['app_served'] / 1024:.0f} kB as served); "
        f"sign-in page baseline {sizes['pages_gzip'] / 1024:.0f} kB gzip; budget {SHELL_BUDGET_KB} kB"
    )
    for label, times in start.items():
        print(f"start {label}: median {statistics.median(times):.2f} s, max {max(times):.2f} s (runs {len(times)})")
    for rate, (values, parts) in check.items():
        split = ", ".join(f"{k} {median:.1f} (p95 {high:.1f})" for k, (median, high) in parts.items())
        print(f"check at {rate}x CPU: median {statistics.median(values):.1f} ms, p95 {p95(values):.1f} ms ({split})")
    print(
        f"verdicts: {agreement['photos']} photos; phone and gateway agree on accepting {agreement['accepted_agree']}, "
        f"on every reason {agreement['same_reasons']}; reasons that differ: {agreement['differing'] or 'none'}"
    )
    print(
        f"queue: {queued['photos']} photos, {queued['mb']:.0f} MB in {queued['seconds']:.1f} s, all kept byte for "
        f"byte: {queued['all_kept']}; baseline file write {queued['baseline_s']:.2f} s"
    )


if __name__ == "__main__":
    main()
