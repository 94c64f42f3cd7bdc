"""Accounts, roles, phone pairing, revocation and login throttling over the real app."""

from __future__ import annotations

import re
import threading

import pytest
from litestar.testing import TestClient

from base.web.pages.session import is_page_path
from harness.bodies import encounter_body, now, patient_body
from harness.processes import PASSWORD, login
from schemas.accounts import Role
from schemas.errors import AuthenticationFailed, TooManyAttempts
from schemas.ids import uuid7
from tests.conftest import make_user

# The ways in (logging in, pairing a phone) and what a phone needs before it can: the capture settings, the
# marker sheet, the gateway's certificate authority and the setup page, none holding patient data. Everything else
# needs a session.
UNAUTHENTICATED = {
    ("POST", "/api/v1/auth/login"),
    ("POST", "/api/v1/auth/pair"),
    ("GET", "/health"),
    ("GET", "/sign-in"),
    ("POST", "/sign-in"),
    ("GET", "/api/v1/capture/settings"),
    ("GET", "/marker-sheet.pdf"),
    ("GET", "/ca.crt"),
    ("GET", "/phone-setup"),
}


def _concrete(path: str) -> str:
    return re.sub(r"\{[^}]+\}", uuid7(), path)


def test_every_endpoint_except_health_and_the_ways_in_requires_authentication(app, client):
    checked = 0
    for route in app.routes:
        # The API docs, the pages' static files and the phone app's own files are public (tests/test_page_assets.py).
        if route.path.startswith(("/schema", "/static/", "/app")):
            continue
        for method in sorted(route.methods - {"OPTIONS", "HEAD"}):
            if (method, route.path) in UNAUTHENTICATED:
                continue
            r = client.request(method, _concrete(route.path), json={}, follow_redirects=False)
            if is_page_path(route.path):
                # A browser page: reading one sends to the sign-in form; a write without its CSRF token is refused
                # before anything else is looked at.
                expected = 303 if method == "GET" else 403
                assert r.status_code == expected, f"{method} {route.path} answered {r.status_code}"
                if method == "GET":
                    assert r.headers["location"].startswith("/sign-in?next=")
            else:
                assert r.status_code == 401, f"{method} {route.path} answered {r.status_code}"
                assert r.headers["content-type"].startswith("application/problem+json")
            checked += 1
    assert checked >= 30


def test_a_bad_or_missing_token_is_refused(client):
    assert client.get("/api/v1/patients", headers={"Authorization": "Bearer nonsense"}).status_code == 401
    assert client.get("/api/v1/patients", headers={"Authorization": "Basic abc"}).status_code == 401


def test_passwords_are_stored_as_argon2id_hashes(services):
    make_user(services, "dr.who", Role.clinician)
    stored = services.db.connection().execute("SELECT password_hash FROM users").fetchone()[0]
    assert stored.startswith("$argon2id$") and PASSWORD not in stored


def test_roles_limit_what_each_user_may_do(client, auth):
    clin, nurse, consultant, admin = (auth[r] for r in ("clinician", "nurse", "consultant", "admin"))
    p = patient_body()
    assert client.post("/api/v1/patients", json=p, headers=nurse).status_code == 201
    e = encounter_body(p["id"])
    assert client.post("/api/v1/encounters", json=e, headers=nurse).status_code == 201
    chart = {
        "encounter_id": e["id"],
        "assessed_at": now().isoformat(),
        "entries": [{"region": "trunk_anterior", "fraction": 0.5, "depth": "deep_partial"}],
    }
    url = f"/api/v1/encounters/{e['id']}/burn-chart"
    assert client.put(url, json=chart, headers={**nurse, "If-None-Match": "*"}).status_code == 403
    assert client.put(url, json=chart, headers={**consultant, "If-None-Match": "*"}).status_code == 403
    assert client.put(url, json=chart, headers={**clin, "If-None-Match": "*"}).status_code == 201
    assert client.get(url, headers=consultant).status_code == 200
    assert client.get(f"/api/v1/patients/{p['id']}", headers=admin).status_code == 403
    assert client.get("/api/v1/patients", headers=admin).status_code == 403
    withdraw = {"params": {"reason": "test"}, "headers": {**nurse, "If-Match": '"1"'}}
    assert client.delete(f"/api/v1/patients/{p['id']}", **withdraw).status_code == 403
    assert (
        client.post(
            "/api/v1/admin/users", json={"username": "x1", "password": PASSWORD, "role": "admin"}, headers=clin
        ).status_code
        == 403
    )
    assert client.get("/api/v1/admin/audit", headers=clin).status_code == 403
    assert client.get("/api/v1/admin/audit", headers=admin).status_code == 200
    # the admin sees no clinical record in the change feed either
    assert client.get("/api/v1/sync/changes", headers=admin).json()["changes"] == []


def test_admin_creates_users_and_usernames_are_unique(client, auth):
    admin = auth["admin"]
    body = {"username": "nurse.joy", "password": PASSWORD, "role": "nurse", "display_name": "Joy"}
    assert client.post("/api/v1/admin/users", json=body, headers=admin).status_code == 201
    assert client.post("/api/v1/admin/users", json=body, headers=admin).status_code == 409
    short = {**body, "username": "nurse.kim", "password": "short"}
    assert client.post("/api/v1/admin/users", json=short, headers=admin).status_code == 400
    login(client, "nurse.joy")


def _pair(client, admin, name="ward phone") -> str:
    code = client.post("/api/v1/admin/pairing-codes", json={"device_name": name}, headers=admin).json()["code"]
    r = client.post("/api/v1/auth/pair", json={"code": code.lower(), "device_fingerprint": "android-1234"})
    assert r.status_code == 201, r.text
    return r.json()


def test_pairing_code_is_single_use_and_gives_a_device_token(client, auth):
    admin = auth["admin"]
    code = client.post("/api/v1/admin/pairing-codes", json={"device_name": "bay 3"}, headers=admin).json()["code"]
    assert re.fullmatch(r"[A-Z2-9]{4}-[A-Z2-9]{4}", code)
    assert client.post("/api/v1/auth/pair", json={"code": code}).status_code == 201
    again = client.post("/api/v1/auth/pair", json={"code": code})
    wrong = client.post("/api/v1/auth/pair", json={"code": "ABCD-EFGH"})
    assert again.status_code == wrong.status_code == 401
    assert again.json()["detail"] == wrong.json()["detail"]  # nothing to learn about which codes exist
    devices = client.get("/api/v1/admin/devices", headers=admin).json()
    assert [d["name"] for d in devices] == ["bay 3"]


def test_expired_pairing_code_is_refused(client, auth, services):
    code = client.post("/api/v1/admin/pairing-codes", json={"device_name": "old"}, headers=auth["admin"]).json()["code"]
    services.db.connection().execute("UPDATE pairing_codes SET expires_at = '2000-01-01T00:00:00+00:00'")
    r = client.post("/api/v1/auth/pair", json={"code": code})
    assert r.status_code == 401 and "not valid" in r.json()["detail"]


def test_a_revoked_device_token_stops_working_at_once(client, auth):
    device = _pair(client, auth["admin"])
    phone = login(client, "clinician", device_token=device["device_token"])
    me = client.get("/api/v1/auth/me", headers=phone).json()
    assert me["device_id"] == device["device_id"]
    assert client.get("/api/v1/patients", headers=phone).status_code == 200
    revoked = client.post(f"/api/v1/admin/devices/{device['device_id']}/revoke", headers=auth["admin"])
    assert revoked.status_code == 200 and revoked.json()["revoked_at"] is not None
    refused = client.get("/api/v1/patients", headers=phone)
    assert refused.status_code == 401 and "revoked" in refused.json()["detail"]
    relogin = client.post(
        "/api/v1/auth/login",
        json={"username": "clinician", "password": PASSWORD},
        headers={"X-Device-Token": device["device_token"]},
    )
    assert relogin.status_code == 401 and "revoked" in relogin.json()["detail"]
    # other sessions are untouched
    assert client.get("/api/v1/patients", headers=auth["clinician"]).status_code == 200


def test_writes_from_a_paired_phone_record_the_device(client, auth, services):
    device = _pair(client, auth["admin"])
    phone = login(client, "clinician", device_token=device["device_token"])
    r = client.post("/api/v1/patients", json=patient_body(), headers=phone)
    assert r.json()["meta"]["device_id"] == device["device_id"]
    row = services.db.connection().execute("SELECT device_id FROM audit_log WHERE action = 'record.create'").fetchone()
    assert row[0] == device["device_id"]


def test_logout_ends_the_session(client, auth):
    assert client.post("/api/v1/auth/logout", headers=auth["nurse"]).status_code == 204
    assert client.get("/api/v1/patients", headers=auth["nurse"]).status_code == 401


def test_repeated_failed_logins_are_slowed_down(client, services):
    make_user(services, "target", Role.clinician)
    free = services.config.security.login_free_failures
    for _ in range(free):
        r = client.post("/api/v1/auth/login", json={"username": "target", "password": "wrong password!"})
        assert r.status_code == 401
    locked = client.post("/api/v1/auth/login", json={"username": "target", "password": "wrong password!"})
    assert locked.status_code == 401  # this failure triggers the lock-out
    r = client.post("/api/v1/auth/login", json={"username": "target", "password": PASSWORD})
    assert r.status_code == 429
    assert int(r.headers["retry-after"]) >= 1
    assert "wait" in r.json()["detail"]
    # once the lock-out has passed, the right password works and resets the count
    services.db.connection().execute("UPDATE login_throttle SET locked_until = '2000-01-01T00:00:00+00:00'")
    assert client.post("/api/v1/auth/login", json={"username": "target", "password": PASSWORD}).status_code == 200


def test_lockout_grows_with_further_failures(client, services):
    make_user(services, "victim", Role.nurse)
    cfg = services.config.security
    delays = []
    for _ in range(cfg.login_free_failures + 3):
        services.db.connection().execute("UPDATE login_throttle SET locked_until = NULL")
        client.post("/api/v1/auth/login", json={"username": "victim", "password": "not the password"})
        r = client.post("/api/v1/auth/login", json={"username": "victim", "password": "not the password"})
        if r.status_code == 429:
            delays.append(int(r.headers["retry-after"]))
    assert delays == sorted(delays) and delays[-1] > delays[0]


def test_unknown_user_fails_like_a_wrong_password(client):
    r = client.post("/api/v1/auth/login", json={"username": "nobody", "password": PASSWORD})
    assert r.status_code == 401 and r.json()["detail"] == "wrong username or password"


@pytest.mark.parametrize("role", list(Role))
def test_me_reports_the_role(client, auth, role):
    assert client.get("/api/v1/auth/me", headers=auth[role.value]).json()["role"] == role.value


def test_parallel_guesses_cannot_slip_past_the_throttle(services):
    make_user(services, "racer", Role.clinician)
    free = services.config.security.login_free_failures
    barrier = threading.Barrier(16)
    outcomes: list[str] = []

    def guess() -> None:
        barrier.wait()
        try:
            services.accounts.login("racer", "not the password", client="10.0.0.9", device_token=None)
        except AuthenticationFailed:
            outcomes.append("checked")
        except TooManyAttempts:
            outcomes.append("throttled")

    threads = [threading.Thread(target=guess) for _ in range(16)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert outcomes.count("checked") <= free + 1
    assert outcomes.count("throttled") >= 16 - free - 1


def test_failed_logins_keep_counting_while_attempts_continue(client, services):
    make_user(services, "slow", Role.nurse)
    conn = services.db.connection()
    for _ in range(services.config.security.login_free_failures + 2):
        conn.execute("UPDATE login_throttle SET locked_until = NULL")
        client.post("/api/v1/auth/login", json={"username": "slow", "password": "not the password"})
    # an attacker who waits out each lock does not get a fresh count
    failures = conn.execute("SELECT failures FROM login_throttle WHERE key = 'user:slow'").fetchone()[0]
    assert failures == services.config.security.login_free_failures + 2


def test_a_good_login_from_a_shared_address_does_not_lock_it(client, services):
    make_user(services, "ward.a", Role.nurse)
    for _ in range(services.config.security.login_free_failures + 3):
        login(client, "ward.a")  # a busy clinic behind one address


def test_failed_login_audit_does_not_keep_what_was_typed(client, services):
    client.post("/api/v1/auth/login", json={"username": "MySecretPassw0rd", "password": "x"})
    details = [r[0] for r in services.db.connection().execute("SELECT detail FROM audit_log")]
    assert "unknown username" in details and not any("MySecretPassw0rd" in d for d in details)


def test_an_expired_session_is_refused(client, auth, services):
    services.db.connection().execute("UPDATE sessions SET expires_at = '2000-01-01T00:00:00+00:00'")
    r = client.get("/api/v1/patients", headers=auth["clinician"])
    assert r.status_code == 401 and "expired" in r.json()["detail"]


def test_a_disabled_account_is_locked_out_at_once(client, auth, services):
    admin = auth["admin"]
    nurse_id = client.get("/api/v1/auth/me", headers=auth["nurse"]).json()["user_id"]
    r = client.post(f"/api/v1/admin/users/{nurse_id}/disable", headers=admin)
    assert r.status_code == 200 and r.json()["active"] is False
    assert client.get("/api/v1/patients", headers=auth["nurse"]).status_code == 401
    refused = client.post("/api/v1/auth/login", json={"username": "nurse", "password": PASSWORD})
    assert refused.status_code == 401 and "disabled" in refused.json()["detail"]
    assert client.post(f"/api/v1/admin/users/{nurse_id}/enable", headers=admin).status_code == 200
    login(client, "nurse")
    admin_id = client.get("/api/v1/auth/me", headers=admin).json()["user_id"]
    assert client.post(f"/api/v1/admin/users/{admin_id}/disable", headers=admin).status_code == 409


def test_pairing_attempts_are_throttled(client, services):
    for _ in range(services.config.security.login_free_failures + 1):
        assert client.post("/api/v1/auth/pair", json={"code": "WXYZ-2345"}).status_code == 401
    assert client.post("/api/v1/auth/pair", json={"code": "WXYZ-2345"}).status_code == 429


def _valid_body(path: str, record_id: str) -> dict | None:
    t = now().isoformat()
    part = path.rsplit("/", 1)[-1]
    bodies = {
        "intake": {"encounter_id": record_id},
        "resuscitation": {"encounter_id": record_id},
        "primary-survey": {"encounter_id": record_id, "assessed_at": t},
        "secondary-survey": {"encounter_id": record_id, "assessed_at": t},
        "burn-chart": {"encounter_id": record_id, "assessed_at": t},
        "mechanism": {"encounter_id": record_id, "type": "scald"},
        "analyses": {},
        "acts": {"key": "tetanus", "state": "accepted"},
        "decision-support": None,
        "merge": {"duplicate_id": uuid7(), "reason": "registered twice"},
    }
    if part in bodies:
        return bodies[part]
    wound = {"regions": ["lower_arm_left_anterior"], "label": "left forearm"}
    if part == "wounds":
        return {"id": uuid7(), "patient_id": record_id, **wound}
    if path.startswith("/api/v1/wounds"):
        return {"id": record_id, "patient_id": uuid7(), **wound}
    if path.startswith("/api/v1/patients"):
        return patient_body(record_id)
    if path.startswith("/api/v1/encounters") and part not in ("assessment",):
        return encounter_body(uuid7(), record_id)
    return None


def test_an_administrator_is_refused_every_clinical_route(app, client, auth):
    checked = 0
    for route in app.routes:
        if not route.path.startswith(("/api/v1/patients", "/api/v1/encounters", "/api/v1/wounds")):
            continue
        for method in sorted(route.methods - {"OPTIONS", "HEAD"}):
            record_id = uuid7()
            path = re.sub(r"\{[^}]+\}", record_id, route.path)
            body = _valid_body(route.path, record_id) if method in ("POST", "PUT") else None
            params = {"reason": "x"} if method == "DELETE" else None
            r = client.request(method, path, json=body, params=params, headers={**auth["admin"], "If-Match": '"1"'})
            assert r.status_code == 403, f"{method} {route.path}: {r.status_code} {r.text[:200]}"
            checked += 1
    assert checked >= 25
    push = {
        "mutations": [
            {
                "mutation_id": uuid7(),
                "kind": "patient",
                "id": (pid := uuid7()),
                "op": "create",
                "data": patient_body(pid),
            }
        ]
    }
    assert client.post("/api/v1/sync/push", json=push, headers=auth["admin"]).json()["rejected"] == 1


def test_a_clinic_can_require_paired_phones_for_some_roles(tmp_path):
    import msgspec

    from gateway.app import create_app
    from schemas.config import Config, GatewayConfig
    from tests.conftest import FAST_SECURITY

    security = msgspec.structs.replace(FAST_SECURITY, paired_device_roles=["nurse"])
    app = create_app(Config(gateway=GatewayConfig(database=str(tmp_path / "p.sqlite3")), security=security))
    with TestClient(app) as c:
        make_user(app.state.services, "nurse", Role.nurse)
        make_user(app.state.services, "admin", Role.admin)
        r = c.post("/api/v1/auth/login", json={"username": "nurse", "password": PASSWORD})
        assert r.status_code == 401 and "paired phone" in r.json()["detail"]
        device = _pair(c, login(c, "admin"))
        login(c, "nurse", device_token=device["device_token"])
