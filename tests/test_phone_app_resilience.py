"""The phone app when things go wrong, in a real Chromium against a real gateway process: the gateway restarted in
the middle of an upload (over a slow link) loses nothing and the upload resumes; a phone whose storage is nearly
full refuses the next photo with a message a nurse can act on, and keeps the ones it has."""

from __future__ import annotations

import hashlib
import os
import subprocess
from pathlib import Path

import httpx
import pytest

from harness.browser import CHROMIUM, CHROMIUM_ARGS, browser_missing, shot
from harness.phone_app import (
    PHONE_PHOTOS,
    gateway_with_staff,
    pair_and_sign_in,
    pairing_code,
    phone_context,
    phone_photos,
    poll,
    staff_headers,
)
from harness.sites import noise_photo
from tests.capture_images import video as clip

pytestmark = pytest.mark.skipif(bool(browser_missing()), reason=browser_missing() or "browser present")
SLOW_UPLOAD = 300 * 1024
"""Bytes per second up: a 4 MB photo takes about 14 s, time enough to stop the gateway in the middle."""


@pytest.fixture
def gateway(tmp_path):
    process = gateway_with_staff(tmp_path)
    process.start()
    yield process
    process.stop()


def _photos(folder: Path, count: int) -> list[Path]:
    """Phone-sized photos of noise (about 4 MB each: noise does not compress)."""
    return [noise_photo(folder / f"photo-{i}.jpg", i, size=(1600, 1200), quality=97) for i in range(count)]


def _to_capture(page, url: str) -> None:
    """A patient, an encounter, then the capture screen (no wound: the patient has one burn)."""
    page.get_by_label("Given name").fill("Rosa")
    page.get_by_label("Family name").fill("Resilient")
    page.get_by_role("button", name="Add patient").click()
    page.get_by_role("button", name="Start encounter").click()
    page.get_by_role("heading", name="Photograph").wait_for()
    page.get_by_role("link", name="Photograph the burn").click()
    page.locator("#fallback").wait_for(state="attached")


def test_a_gateway_restarted_in_the_middle_of_an_upload_loses_nothing(gateway, browser, tmp_path):
    context = phone_context(browser)
    page = context.new_page()
    try:
        pair_and_sign_in(page, gateway.url, pairing_code(gateway.url))
        _to_capture(page, gateway.url)
        poll(page, "document.getElementById('queue-status').textContent.includes('nothing waiting')", 60)
        link = context.new_cdp_session(page)
        link.send("Network.enable")
        slow = {"offline": False, "latency": 20, "downloadThroughput": -1, "uploadThroughput": SLOW_UPLOAD}
        link.send("Network.emulateNetworkConditions", slow)
        files = _photos(tmp_path, 2)
        page.locator("#fallback").set_input_files([str(f) for f in files])
        poll(page, "document.getElementById('taken').textContent.startsWith('2 photos')")
        page.evaluate("window.dispatchEvent(new Event('online'))")
        poll(page, "fetch('/health').then(() => true)")
        # The first photo is on its way: the gateway stops (SIGTERM), then starts again on the same database.
        started = poll(
            page, f"({PHONE_PHOTOS})().then((ps) => ps.some((p) => p.state === 'uploading' && p.upload_url))", 60
        )
        gateway.stop()
        gateway.start()
        link.send("Network.emulateNetworkConditions", {**slow, "uploadThroughput": -1})
        page.evaluate("window.dispatchEvent(new Event('online'))")
        stored = poll(
            page,
            f"({PHONE_PHOTOS})().then((ps) => ps.length === 2 && ps.every((p) => p.state === 'stored') && ps)",
            120,
        )
        shot(page, "phone-resumed")
    finally:
        context.close()
    assert started
    headers = staff_headers(gateway.url)
    sent = {hashlib.sha256(f.read_bytes()).hexdigest() for f in files}
    kept = set()
    for photo in stored:
        body = httpx.get(f"{gateway.url}/api/v1/assets/{photo['asset']['id']}/file", headers=headers).content
        kept.add(hashlib.sha256(body).hexdigest())
    assert kept == sent == {p["sha256"] for p in stored}  # byte for byte, each once


@pytest.fixture
def small_disk(tmp_path):
    """A 64 MB file system for the phone browser's profile: its storage really runs out."""
    if os.geteuid() != 0:
        pytest.skip("mounting a small tmpfs needs root")
    disk = tmp_path / "phone-disk"
    disk.mkdir()
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64m", "tmpfs", str(disk)], capture_output=True)
    if mounted.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs: {mounted.stderr.decode().strip()}")
    yield disk
    subprocess.run(["umount", "-l", str(disk)], capture_output=True)


def test_a_full_phone_refuses_the_next_photo_with_the_reason_and_keeps_the_others(
    gateway, playwright, small_disk, tmp_path
):
    files = _photos(tmp_path, 20)
    # The phone's own profile on the small disk.
    context = playwright.chromium.launch_persistent_context(
        str(small_disk / "profile"),
        executable_path=str(CHROMIUM),
        args=CHROMIUM_ARGS,
        viewport={"width": 390, "height": 844},
    )
    try:
        page = context.new_page()
        pair_and_sign_in(page, gateway.url, pairing_code(gateway.url))
        _to_capture(page, gateway.url)
        context.set_offline(True)  # nothing leaves: the queue only grows
        message = ""
        for n, photo in enumerate(files, start=1):
            page.locator("#fallback").set_input_files([str(photo)])
            poll(
                page,
                f"document.getElementById('taken').textContent.startsWith('{n} photos') || "
                "document.getElementById('banner').textContent.includes('not kept')",
                30,
            )
            message = page.locator("#banner").inner_text()
            if "not kept" in message:
                break
        shot(page, "phone-storage-full", readme="app-storage-full.png")
        kept = phone_photos(page)
    finally:
        context.close()
    assert "storage is" in message.lower() and "upload the photos waiting" in message, message
    assert 0 < len(kept) < len(files)  # the disk filled before the last photo
    taken = {hashlib.sha256(f.read_bytes()).hexdigest() for f in files[: len(kept)]}
    assert {p["sha256"] for p in kept} == taken  # every photo before the refused one is still there


def test_a_short_video_instead_of_stills_reaches_the_gateway_as_a_video(gateway, browser, tmp_path):
    video = tmp_path / "round.mp4"
    clip(video)  # two seconds of H.264, as a phone films
    context = phone_context(browser)
    page = context.new_page()
    try:
        pair_and_sign_in(page, gateway.url, pairing_code(gateway.url))
        _to_capture(page, gateway.url)
        page.locator("#video").set_input_files([str(video)])
        stored = poll(
            page,
            "(window.dispatchEvent(new Event('online')), "
            + f"({PHONE_PHOTOS})().then((ps) => ps.find((p) => p.state === 'stored') || false))",
            60,
        )
    finally:
        context.close()
    headers = staff_headers(gateway.url)
    asset = httpx.get(f"{gateway.url}/api/v1/assets/{stored['asset']['id']}", headers=headers).json()
    assert asset["kind"] == "video" and asset["sha256"] == hashlib.sha256(video.read_bytes()).hexdigest()
    assert stored["asset"]["verdict"] is None  # a video has no verdict of its own: its frames are judged
