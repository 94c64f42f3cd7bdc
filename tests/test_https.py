"""HTTPS on the clinic's Wi-Fi: the gateway's own authority and certificate, and a real Chromium that trusts the
authority through an NSS database (certutil) opening the phone app at a non-loopback address, where its service
worker registers; a browser that does not trust it is refused; plain HTTP redirects everything but the setup."""

from __future__ import annotations

import datetime as dt
import os
import shutil
import subprocess
from pathlib import Path

import httpx
import pytest
from cryptography import x509

from gateway import tls
from harness.browser import CHROMIUM, CHROMIUM_ARGS, browser_missing
from harness.processes import GatewayProcess, free_port, wait_healthy
from schemas.config import GatewayConfig

LAN_ADDRESS = "10.123.45.1"
"""An address on this machine that is not loopback (added to lo for the test): what a phone on the Wi-Fi uses."""


def test_the_authority_is_made_once_and_the_certificate_names_every_address(tmp_path: Path):
    ca = tls.ensure_ca(tmp_path, "Test clinic")
    assert tls.ensure_ca(tmp_path, "Test clinic").serial_number == ca.serial_number
    assert oct((tmp_path / tls.CA_KEY).stat().st_mode & 0o777) == "0o600"
    first = tls.server_certificate(tmp_path, "Test clinic", ["gateway.clinic.lan", "10.9.8.7"])
    assert "gateway.clinic.lan" in first.names and "10.9.8.7" in first.addresses and "127.0.0.1" in first.addresses
    leaf = x509.load_pem_x509_certificate(first.cert.read_bytes())
    leaf.verify_directly_issued_by(ca)
    assert dt.timedelta(days=396) < leaf.not_valid_after_utc - leaf.not_valid_before_utc < dt.timedelta(days=398)
    again = tls.server_certificate(tmp_path, "Test clinic", ["gateway.clinic.lan"])
    assert x509.load_pem_x509_certificate(again.cert.read_bytes()).serial_number == leaf.serial_number
    renamed = tls.server_certificate(tmp_path, "Test clinic", ["other.clinic.lan"])
    assert "other.clinic.lan" in renamed.names  # a new name: issued again


def test_a_certificate_near_expiry_is_issued_again(tmp_path: Path, monkeypatch):
    first = x509.load_pem_x509_certificate(tls.server_certificate(tmp_path, "c", []).cert.read_bytes())
    later = dt.datetime.now(dt.UTC) + dt.timedelta(days=tls.SERVER_DAYS - tls.RENEW_DAYS + 1)
    monkeypatch.setattr(tls, "_now", lambda: later)
    renewed = x509.load_pem_x509_certificate(tls.server_certificate(tmp_path, "c", []).cert.read_bytes())
    assert renewed.serial_number != first.serial_number and renewed.not_valid_after_utc > first.not_valid_after_utc


def test_https_is_wanted_beyond_loopback_and_needs_its_own_port():
    assert not tls.https_wanted(GatewayConfig()) and tls.https_wanted(GatewayConfig(host="0.0.0.0"))
    assert not tls.https_wanted(GatewayConfig(host="0.0.0.0", https="off"))
    with pytest.raises(Exception, match="https_port"):
        GatewayConfig(https="on", port=8443, https_port=8443)


@pytest.fixture(scope="module")
def lan_gateway(tmp_path_factory):
    if os.geteuid() != 0 or shutil.which("ip") is None:
        pytest.skip("adding a non-loopback address needs root and iproute2")
    added = subprocess.run(["ip", "addr", "add", f"{LAN_ADDRESS}/32", "dev", "lo"], capture_output=True, text=True)
    if added.returncode != 0 and "File exists" not in added.stderr:
        pytest.skip(f"cannot add {LAN_ADDRESS} to lo: {added.stderr.strip()}")
    folder = tmp_path_factory.mktemp("https")
    process = GatewayProcess(folder / "gateway.sqlite3", free_port())
    https_port = free_port()
    process.env.update({"BURNEDGE_GATEWAY_HOST": LAN_ADDRESS, "BURNEDGE_GATEWAY_HTTPS_PORT": str(https_port)})
    process.url = f"http://{LAN_ADDRESS}:{process.port}"
    process.start()
    wait_healthy(process.proc, process.url, process.log, 30, "gateway")
    try:
        yield process, f"https://{LAN_ADDRESS}:{https_port}", folder
    finally:
        process.stop()
        subprocess.run(["ip", "addr", "del", f"{LAN_ADDRESS}/32", "dev", "lo"], capture_output=True)


def test_plain_http_gives_the_authority_and_redirects_the_rest(lan_gateway):
    process, secure, _ = lan_gateway
    moved = httpx.get(f"{process.url}/app/?x=1", follow_redirects=False)
    assert moved.status_code == 308 and moved.headers["location"] == f"{secure}/app/?x=1"
    login = httpx.post(f"{process.url}/api/v1/auth/login", json={"username": "a", "password": "b"})
    assert login.status_code == 308  # a password never goes over plain HTTP on the network
    authority = httpx.get(f"{process.url}/ca.crt")
    assert authority.status_code == 200 and authority.headers["content-type"] == "application/x-x509-ca-cert"
    setup = httpx.get(f"{process.url}/phone-setup")
    fingerprint = tls.fingerprint(x509.load_der_x509_certificate(authority.content))
    assert setup.status_code == 200 and fingerprint in setup.text and f"{secure}/app/" in setup.text
    trusted = httpx.get(f"{secure}/health", verify=False)
    assert trusted.status_code == 200


@pytest.mark.skipif(bool(browser_missing()) or shutil.which("certutil") is None, reason="Chromium and certutil")
def test_a_phone_that_trusts_the_authority_opens_the_app_over_https_and_its_worker_registers(lan_gateway, tmp_path):
    from playwright.sync_api import Error as PlaywrightError
    from playwright.sync_api import sync_playwright

    process, secure, _ = lan_gateway
    home = tmp_path / "home"
    nssdb = home / ".pki" / "nssdb"
    nssdb.mkdir(parents=True)
    (tmp_path / "ca.crt").write_bytes(httpx.get(f"{process.url}/ca.crt").content)
    subprocess.run(["certutil", "-N", "-d", f"sql:{nssdb}", "--empty-password"], check=True)
    subprocess.run(
        ["certutil", "-A", "-d", f"sql:{nssdb}", "-n", "burnedge", "-t", "C,,", "-i", str(tmp_path / "ca.crt")],
        check=True,
    )
    with sync_playwright() as playwright:
        stranger = playwright.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
        try:
            with pytest.raises(PlaywrightError, match="ERR_CERT_AUTHORITY_INVALID"):
                stranger.new_page().goto(f"{secure}/app/")
        finally:
            stranger.close()
        phone = playwright.chromium.launch(
            executable_path=str(CHROMIUM), args=CHROMIUM_ARGS, env={**os.environ, "HOME": str(home)}
        )
        try:
            page = phone.new_page()
            page.goto(f"{secure}/app/")
            assert page.evaluate("window.isSecureContext") is True
            scope = page.evaluate("navigator.serviceWorker.ready.then((r) => r.scope)")
            assert scope == f"{secure}/app/"
        finally:
            phone.close()
