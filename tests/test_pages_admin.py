"""The administrator's page over the real app (TestClient): accounts, pairing codes, paired phones and the audit
check, with the API's roles, validation and CSRF."""

from __future__ import annotations

import re

import pytest

from harness.processes import PASSWORD
from schemas.accounts import PairingCodeRequest, PairRequest, Role
from schemas.errors import AuthenticationFailed
from tests.conftest import make_user
from tests.pages_helpers import csrf_from, post_form, sign_in

_CODE = re.compile(r"(?<![\w-])[A-Z0-9]{4}-[A-Z0-9]{4}(?![\w-])")
"""A pairing code as shown; not two all-digit groups inside an id (a UUID's "4276-7096" made this test flaky)."""


@pytest.fixture
def admin(client, services):
    make_user(services, "ada", Role.admin)
    sign_in(client, "ada", next="/admin")
    return client


def _user(services, username: str):
    return next(u for u in services.accounts.list_users(None) if u.username == username)


def _new_user(client, **fields):
    return post_form(client, "/admin/users", fields, from_page="/admin")


def _sign_out(client) -> None:
    client.post("/sign-out", data={"csrf_token": csrf_from(client.get("/admin").text)})


def test_admins_start_on_the_admin_page(admin):
    r = admin.get("/", follow_redirects=False)
    assert r.status_code == 303 and r.headers["location"] == "/admin"
    page = admin.get("/admin").text
    for heading in ("User accounts", "New account", "Phones", "Audit trail"):
        assert heading in page
    assert "ada" in page and "This is you." in page


def test_an_admin_creates_a_user_who_can_then_sign_in(admin, services):
    r = _new_user(admin, username="nora", password="a-long-password", role="nurse", display_name="Nora N.")
    assert r.status_code == 303 and r.headers["location"] == "/admin?done=user-created"
    page = admin.get(r.headers["location"]).text
    assert "The account was created" in page and "nora" in page and "Nora N." in page
    assert _user(services, "nora").role == Role.nurse
    _sign_out(admin)
    sign_in(admin, "nora", password="a-long-password")


def test_a_duplicate_username_shows_an_error_and_stores_nothing(admin, services):
    make_user(services, "nora", Role.nurse)
    before = len(services.accounts.list_users(None))
    r = _new_user(admin, username="nora", password="a-long-password", role="clinician")
    assert r.status_code == 409
    assert "is taken" in r.text and 'value="nora"' in r.text and "Nothing was stored" in r.text
    assert len(services.accounts.list_users(None)) == before
    assert _user(services, "nora").role == Role.nurse


def test_invalid_input_is_shown_again_with_what_was_typed_and_nothing_stored(admin, services):
    before = len(services.accounts.list_users(None))
    r = _new_user(admin, username="nora", password="short", role="nurse")
    assert r.status_code == 422
    assert "at least 10 characters" in r.text and 'value="nora"' in r.text
    assert 'value="short"' not in r.text  # a password is never written back into the page
    assert len(services.accounts.list_users(None)) == before


def test_deactivate_and_reactivate_a_user(admin, services):
    make_user(services, "nora", Role.nurse)
    nora = _user(services, "nora")
    r = post_form(admin, f"/admin/users/{nora.id}/deactivate", {}, from_page="/admin")
    assert r.status_code == 303 and not _user(services, "nora").active
    assert "deactivated" in admin.get(r.headers["location"]).text
    with pytest.raises(AuthenticationFailed):
        services.accounts.login("nora", PASSWORD, client="test", device_token=None)
    r = post_form(admin, f"/admin/users/{nora.id}/reactivate", {}, from_page="/admin")
    assert r.status_code == 303 and _user(services, "nora").active


def test_the_service_refusal_is_shown_on_the_row(admin, services):
    ada = _user(services, "ada")
    r = post_form(admin, f"/admin/users/{ada.id}/deactivate", {}, from_page="/admin")
    assert r.status_code == 409 and "you cannot disable your own account" in r.text
    assert _user(services, "ada").active


def test_a_password_reset_is_temporary(admin, services):
    make_user(services, "nora", Role.nurse)
    nora = _user(services, "nora")
    url = f"/admin/users/{nora.id}/reset-password"
    short = post_form(admin, url, {"password": "short"}, from_page="/admin")
    assert short.status_code == 422 and "at least 10 characters" in short.text
    assert not _user(services, "nora").must_change_password
    r = post_form(admin, url, {"password": "temporary-1234"}, from_page="/admin")
    assert r.status_code == 303 and r.headers["location"] == "/admin?done=password-reset"
    assert _user(services, "nora").must_change_password
    assert "must change at next sign-in" in admin.get("/admin").text
    session = services.accounts.login("nora", "temporary-1234", client="test", device_token=None)
    assert session.user.must_change_password


def test_a_nurse_gets_403_on_the_page_and_on_every_form(client, services):
    make_user(services, "nina", Role.nurse)
    make_user(services, "nora", Role.nurse)
    token = sign_in(client, "nina")
    nora = _user(services, "nora")
    assert client.get("/admin").status_code == 403
    assert client.get("/admin/audit").status_code == 403
    posts = {
        "/admin/users": {"username": "eve", "password": "a-long-password", "role": "admin"},
        "/admin/users?bad": {"username": "eve", "password": "short", "role": "admin"},
        f"/admin/users/{nora.id}/deactivate": {},
        f"/admin/users/{nora.id}/reset-password": {"password": "temporary-1234"},
        "/admin/pairing-codes": {"device_name": "ward 2 phone"},
        f"/admin/devices/{nora.id}/revoke": {},
    }
    for url, data in posts.items():
        r = client.post(url, data={"csrf_token": token, **data})
        assert r.status_code == 403, (url, r.status_code)
    assert [u.username for u in services.accounts.list_users(None)] == ["nina", "nora"]
    assert _user(services, "nora").active and not _user(services, "nora").must_change_password


def test_a_pairing_code_is_shown_once_and_pairs_a_phone(admin, services):
    r = post_form(admin, "/admin/pairing-codes", {"device_name": "ward 2 phone"}, from_page="/admin")
    assert r.status_code == 201 and r.headers["cache-control"] == "no-store"
    code = _CODE.search(r.text.split("Pairing code for", 1)[1]).group(0)
    assert "ward 2 phone" in r.text
    # The same code as a link the phone's camera opens (the gateway's app, the code in the fragment), as a QR code.
    assert f"http://testserver.local/app/#pair={code}" in r.text and 'class="segno"' in r.text
    assert code not in admin.get("/admin").text
    paired = services.accounts.pair(PairRequest(code=code), client="test")
    assert "ward 2 phone" in admin.get("/admin").text and paired.device_id in admin.get("/admin").text


def test_a_pairing_code_needs_a_device_name(admin):
    r = post_form(admin, "/admin/pairing-codes", {"device_name": "x" * 201}, from_page="/admin")
    assert r.status_code == 422 and "at most 200 characters" in r.text and not _CODE.search(r.text)


def test_revoking_a_phone_stops_its_token(admin, client, services):
    make_user(services, "nora", Role.nurse)
    ada = services.accounts.authenticate(client.cookies["burnedge_session"])
    code = services.accounts.create_pairing_code(ada, PairingCodeRequest(device_name="ward 2 phone"))
    device = services.accounts.pair(PairRequest(code=code.code), client="test")
    session = services.accounts.login("nora", PASSWORD, client="test", device_token=device.device_token)
    bearer = {"Authorization": f"Bearer {session.access_token}"}
    assert client.get("/api/v1/auth/me", headers=bearer).status_code == 200
    page = admin.get("/admin").text
    assert f'action="/admin/devices/{device.device_id}/revoke"' in page and "data-confirm=" in page
    r = post_form(admin, f"/admin/devices/{device.device_id}/revoke", {}, from_page="/admin")
    assert r.status_code == 303 and r.headers["location"] == "/admin?done=device-revoked"
    assert "The phone was revoked" in admin.get(r.headers["location"]).text
    assert client.get("/api/v1/auth/me", headers=bearer).status_code == 401
    with pytest.raises(AuthenticationFailed):
        services.accounts.login("nora", PASSWORD, client="test", device_token=device.device_token)


def test_the_audit_check_shows_ok_and_where_the_chain_breaks(admin, services):
    r = admin.get("/admin/audit")
    assert r.status_code == 200 and "The audit trail is intact" in r.text
    services.db.connection().execute("UPDATE audit_log SET detail = 'nothing happened' WHERE seq = 1")
    broken = admin.get("/admin/audit").text
    assert "The audit trail is broken at entry 1" in broken


def test_a_post_without_the_csrf_token_is_refused(admin, services):
    r = admin.post("/admin/users", data={"username": "nora", "password": "a-long-password", "role": "nurse"})
    assert r.status_code == 403 and "CSRF" in r.text
    assert "nora" not in [u.username for u in services.accounts.list_users(None)]


def test_user_text_is_escaped(admin, services):
    r = _new_user(admin, username="nora", password="a-long-password", role="nurse", display_name="<b>x</b>")
    assert r.status_code == 303
    page = admin.get("/admin").text
    assert "<b>x</b>" not in page and "&lt;b&gt;x&lt;/b&gt;" in page
