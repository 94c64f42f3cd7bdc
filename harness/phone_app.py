"""What the phone app's browser tests and benchmark share: a gateway process with an administrator and a nurse, a
pairing code, a phone-sized context, pairing and signing in as a nurse would, and reading the phone's own photo queue."""

from __future__ import annotations

import time
from pathlib import Path

import httpx

from harness.browser import PHONE
from harness.processes import PASSWORD, GatewayProcess, free_port
from harness.sites import cli

PHONE_PHOTOS = """async () => {
  const db = await new Promise((ok, fail) => { const r = indexedDB.open("burnedge-app"); r.onsuccess = () => ok(r.result); r.onerror = fail; });
  const all = await new Promise((ok) => { const r = db.transaction("photos").objectStore("photos").getAll(); r.onsuccess = () => ok(r.result); });
  db.close();
  return all.map((p) => ({ id: p.id, sha256: p.sha256, state: p.state, asset: p.asset, taken_at: p.taken_at,
    device_verdict: p.device_verdict, disagrees: p.disagrees, upload_url: p.upload_url, error: p.error }));
}"""
"""The phone's photo queue as IndexedDB holds it."""


def gateway_with_staff(folder: Path) -> GatewayProcess:
    """A gateway process (not started) whose database has an administrator and a nurse."""
    process = GatewayProcess(folder / "gateway.sqlite3", free_port())
    for name, role in (("admin", "admin"), ("nurse", "nurse")):
        cli(
            "--db",
            str(process.db),
            "users",
            "add",
            "--username",
            name,
            "--role",
            role,
            "--password-stdin",
            stdin=PASSWORD,
        )
    return process


def pairing_code(url: str, device: str = "ward phone") -> str:
    admin = httpx.post(f"{url}/api/v1/auth/login", json={"username": "admin", "password": PASSWORD}).json()
    headers = {"Authorization": f"Bearer {admin['access_token']}"}
    return httpx.post(f"{url}/api/v1/admin/pairing-codes", json={"device_name": device}, headers=headers).json()["code"]


def staff_headers(url: str, username: str = "nurse") -> dict[str, str]:
    session = httpx.post(f"{url}/api/v1/auth/login", json={"username": username, "password": PASSWORD}).json()
    return {"Authorization": f"Bearer {session['access_token']}"}


def phone_context(browser, **extra):
    return browser.new_context(
        viewport={"width": PHONE[0], "height": PHONE[1]}, has_touch=True, is_mobile=True, **extra
    )


def pair_and_sign_in(page, url: str, code: str) -> None:
    """Open the pairing link, pair, sign in as the nurse; the patients list shows."""
    page.goto(f"{url}/app/#pair={code}")
    page.get_by_role("button", name="Pair").click()
    page.get_by_label("User name").fill("nurse")
    page.get_by_label("Password").fill(PASSWORD)
    page.get_by_role("button", name="Sign in").click()
    page.get_by_role("heading", name="Patients").wait_for()


def poll(page, script: str, timeout_s: float = 30.0):
    """Wait until `script` (evaluated in the page) is truthy; its value."""
    deadline = time.monotonic() + timeout_s
    while not (value := page.evaluate(script)):
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout_s:g} s waiting for {script}")
        page.wait_for_timeout(250)
    return value


def phone_photos(page) -> list[dict]:
    return page.evaluate(PHONE_PHOTOS)


def fake_camera(folder: Path) -> Path:
    """An MJPEG file of a rendered burn phantom seen from around it (8 views, half a second each), for Chromium's
    fake camera (--use-file-for-fake-video-capture)."""
    from harness.phantoms import rendered
    from schemas.phantom import PhantomShape, PhantomSpec

    phantom = folder / "phantom"
    spec = PhantomSpec(shape=PhantomShape.patch, seed=12, area_cm2=16.0, depth_mm=2.5, views=8, width=960, height=720)
    rendered(spec, phantom)
    frames = sorted((phantom / "images").glob("*.jpg"))
    video = folder / "orbit.mjpeg"
    video.write_bytes(b"".join(f.read_bytes() for f in frames for _ in range(15)))
    return video


def camera_args(video: Path) -> list[str]:
    """Chromium flags: a fake camera playing `video`, its permission prompt answered yes."""
    return [
        "--use-fake-ui-for-media-stream",
        "--use-fake-device-for-media-stream",
        f"--use-file-for-fake-video-capture={video}",
    ]
