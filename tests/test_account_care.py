"""Account care: `burnedge users list|passwd|disable|enable` on a real SQLite file, beside a real gateway process that
the accounts then log in to over loopback; an administrator's password reset and a user's own change over HTTP.
Every change is audited, and no audit entry holds a password."""

from __future__ import annotations

import json
import os
import select
import subprocess
import sys
from pathlib import Path

import httpx
import pytest

from harness.processes import FAST_HASH_ENV, PASSWORD, REPO, GatewayProcess, add_user_cli, free_port

pytestmark = pytest.mark.server

TEMPORARY = "temporary pass 4711"
NEW = "a new password of mine"
SECRETS = (PASSWORD, TEMPORARY, NEW, "wrong current one")


def cli(db: Path, *args: str, stdin: str | None = None, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "burnedge.cli", "--db", str(db), "users", *args],
        input=stdin,
        capture_output=True,
        text=True,
        cwd=REPO,
        env={**FAST_HASH_ENV, "PATH": "", **(env or {})},
        timeout=60,
    )


def typed(db: Path, *args: str, answers: tuple[str, str]) -> tuple[int, str]:
    """A CLI call on a terminal (a pty), answering its two password prompts; its exit code and all it wrote."""
    master, slave = os.openpty()
    # A new session has no controlling terminal, so getpass reads the pty given as stdin (with echo off).
    proc = subprocess.Popen(
        [sys.executable, "-m", "burnedge.cli", "--db", str(db), "users", *args],
        stdin=slave,
        stdout=slave,
        stderr=slave,
        cwd=REPO,
        env={**FAST_HASH_ENV, "PATH": ""},
        start_new_session=True,
    )
    os.close(slave)
    seen = b""

    def more() -> bool:
        nonlocal seen
        if not select.select([master], [], [], 30)[0]:
            raise AssertionError(f"the command said nothing more: {seen!r}")
        try:
            chunk = os.read(master, 4096)
        except OSError:  # EIO: the command ended and closed the terminal
            return False
        seen += chunk
        return bool(chunk)

    try:
        for prompt, answer in zip((b"New password: ", b"The same again: "), answers, strict=True):
            while prompt not in seen:  # answering before the prompt would be flushed when getpass turns echo off
                assert more(), f"no prompt {prompt!r}: {seen!r}"
            os.write(master, answer.encode() + b"\n")
        while more():
            pass
        return proc.wait(30), seen.decode(errors="replace")
    finally:
        os.close(master)
        if proc.poll() is None:
            proc.kill()


def bearer(response: httpx.Response) -> dict[str, str]:
    assert response.status_code == 200, response.text
    return {"Authorization": f"Bearer {response.json()['access_token']}"}


@pytest.fixture(scope="module")
def gw(tmp_path_factory) -> GatewayProcess:
    process = GatewayProcess(tmp_path_factory.mktemp("care") / "gateway.sqlite3", free_port())
    add_user_cli(process.db, "admin", "admin")
    # Refused logins are part of these tests; they must not lock loopback out of the ones that follow.
    process.env = {"BURNEDGE_SECURITY_LOGIN_FREE_FAILURES": "100"}
    process.start()
    yield process
    process.stop()


@pytest.fixture
def http(gw: GatewayProcess):
    with httpx.Client(base_url=gw.url, timeout=10) as client:
        yield client


def log_in(http: httpx.Client, username: str, password: str = PASSWORD) -> httpx.Response:
    return http.post("/api/v1/auth/login", json={"username": username, "password": password})


def audited(http: httpx.Client, record_id: str) -> list[dict]:
    """The audit entries about one account (checking on the way that none in the chain holds a password)."""
    entries = http.get("/api/v1/admin/audit", params={"limit": 1000}, headers=bearer(log_in(http, "admin"))).json()
    text = json.dumps(entries)
    assert not any(secret in text for secret in SECRETS), "a password is in the audit trail"
    return [e for e in entries if e["record_id"] == record_id]


def test_users_list_shows_every_account_and_its_state(gw, http):
    add_user_cli(gw.db, "care.list", "nurse")
    r = cli(gw.db, "list")
    assert r.returncode == 0, r.stderr
    users = {u["username"]: u for u in json.loads(r.stdout)}
    assert {"admin", "care.list"} <= set(users)
    assert (users["care.list"]["role"], users["care.list"]["active"], users["care.list"]["must_change_password"]) == (
        "nurse",
        True,
        False,
    )
    assert "password" not in r.stdout.replace("must_change_password", "")


def test_disable_ends_a_live_session_and_enable_lets_the_user_back(gw, http):
    add_user_cli(gw.db, "care.off", "clinician")
    session = bearer(log_in(http, "care.off"))
    user_id = http.get("/api/v1/auth/me", headers=session).json()["user_id"]
    r = cli(gw.db, "disable", "care.off")
    assert r.returncode == 0 and json.loads(r.stdout)["active"] is False, r.stderr
    assert http.get("/api/v1/patients", headers=session).status_code == 401
    refused = log_in(http, "care.off")
    assert refused.status_code == 401 and "disabled" in refused.json()["detail"]
    assert cli(gw.db, "enable", "care.off").returncode == 0
    back = bearer(log_in(http, "care.off"))
    assert http.get("/api/v1/patients", headers=back).status_code == 200
    assert http.get("/api/v1/patients", headers=session).status_code == 401, "enabling does not revive old sessions"

    last = cli(gw.db, "disable", "admin")
    assert last.returncode == 4 and "last active administrator" in last.stderr
    missing = cli(gw.db, "enable", "nobody")
    assert missing.returncode == 3 and "no user named 'nobody'" in missing.stderr
    actions = [(e["action"], e["user_id"]) for e in audited(http, user_id)]
    assert ("user.disable", None) in actions and ("user.enable", None) in actions  # the gateway's command line


def test_a_reset_password_must_be_changed_before_anything_else(gw, http):
    add_user_cli(gw.db, "care.reset", "clinician")
    old = bearer(log_in(http, "care.reset"))
    user_id = http.get("/api/v1/auth/me", headers=old).json()["user_id"]
    admin = bearer(log_in(http, "admin"))
    url = f"/api/v1/admin/users/{user_id}/reset-password"
    assert http.post(url, json={"password": TEMPORARY}, headers=old).status_code == 403, "only an administrator"
    assert http.post(url, json={"password": "short"}, headers=admin).status_code == 400
    r = http.post(url, json={"password": TEMPORARY}, headers=admin)
    assert r.status_code == 200 and r.json()["must_change_password"] is True, r.text
    assert http.get("/api/v1/auth/me", headers=old).status_code == 401, "the reset ends the user's sessions"
    assert log_in(http, "care.reset").status_code == 401, "the old password is gone"
    admin_id = http.get("/api/v1/auth/me", headers=admin).json()["user_id"]
    own = http.post(f"/api/v1/admin/users/{admin_id}/reset-password", json={"password": TEMPORARY}, headers=admin)
    assert own.status_code == 409 and "/api/v1/auth/password" in own.json()["detail"]

    signed_in = log_in(http, "care.reset", TEMPORARY)
    session = bearer(signed_in)
    assert signed_in.json()["user"]["must_change_password"] is True
    me = http.get("/api/v1/auth/me", headers=session)
    assert me.status_code == 200 and me.json()["must_change_password"] is True
    for method, path in (("GET", "/api/v1/patients"), ("POST", "/api/v1/patients"), ("GET", "/api/v1/sync/changes")):
        blocked = http.request(method, path, headers=session, json={})
        assert blocked.status_code == 403, (method, path, blocked.text)
        assert blocked.headers["content-type"].startswith("application/problem+json")
        assert "you must change your password before you go on: POST /api/v1/auth/password" in blocked.json()["detail"]
    same = http.post(
        "/api/v1/auth/password", json={"current_password": TEMPORARY, "new_password": TEMPORARY}, headers=session
    )
    assert same.status_code == 422
    changed = http.post(
        "/api/v1/auth/password", json={"current_password": TEMPORARY, "new_password": NEW}, headers=session
    )
    assert changed.status_code == 200 and changed.json()["must_change_password"] is False, changed.text
    assert http.get("/api/v1/patients", headers=session).status_code == 200, "the session that changed it goes on"
    assert http.get("/api/v1/auth/me", headers=session).json()["must_change_password"] is False
    assert log_in(http, "care.reset", TEMPORARY).status_code == 401
    bearer(log_in(http, "care.reset", NEW))
    actions = [(e["action"], e["user_id"]) for e in audited(http, user_id)]
    assert ("user.password_reset", admin_id) in actions and ("user.password_change", user_id) in actions


def test_changing_your_own_password_needs_the_current_one_and_ends_your_other_sessions(gw, http):
    add_user_cli(gw.db, "care.own", "nurse")
    here, elsewhere = bearer(log_in(http, "care.own")), bearer(log_in(http, "care.own"))
    user_id = http.get("/api/v1/auth/me", headers=here).json()["user_id"]
    wrong = http.post(
        "/api/v1/auth/password", json={"current_password": "wrong current one", "new_password": NEW}, headers=here
    )
    assert wrong.status_code == 403 and "current password is wrong" in wrong.json()["detail"]
    assert http.get("/api/v1/auth/me", headers=elsewhere).status_code == 200, "a refused change changes nothing"
    short = http.post(
        "/api/v1/auth/password", json={"current_password": PASSWORD, "new_password": "short"}, headers=here
    )
    assert short.status_code == 400
    r = http.post("/api/v1/auth/password", json={"current_password": PASSWORD, "new_password": NEW}, headers=here)
    assert r.status_code == 200, r.text
    assert http.get("/api/v1/patients", headers=here).status_code == 200
    assert http.get("/api/v1/auth/me", headers=elsewhere).status_code == 401
    assert log_in(http, "care.own").status_code == 401, "the old password no longer logs in"
    bearer(log_in(http, "care.own", NEW))
    entries = audited(http, user_id)
    assert any(e["action"] == "auth.failed" and "wrong current password" in e["detail"] for e in entries)
    assert [e["detail"] for e in entries if e["action"] == "user.password_change"] == [
        "care.own; 1 other sessions ended"
    ]


def test_users_passwd_sets_a_password_and_with_temporary_forces_a_change(gw, http):
    add_user_cli(gw.db, "care.cli", "clinician")
    session = bearer(log_in(http, "care.cli"))
    user_id = http.get("/api/v1/auth/me", headers=session).json()["user_id"]
    r = cli(gw.db, "passwd", "care.cli", "--password-stdin", stdin=NEW + "\n")
    assert r.returncode == 0 and json.loads(r.stdout)["must_change_password"] is False, r.stderr
    assert http.get("/api/v1/auth/me", headers=session).status_code == 401, "passwd ends the user's sessions"
    assert log_in(http, "care.cli").status_code == 401
    assert http.get("/api/v1/patients", headers=bearer(log_in(http, "care.cli", NEW))).status_code == 200

    code, said = typed(gw.db, "passwd", "care.cli", "--temporary", answers=(TEMPORARY, TEMPORARY + "x"))
    assert code == 2 and "the two passwords differ" in said and TEMPORARY not in said
    assert log_in(http, "care.cli", NEW).status_code == 200, "a refused passwd changes nothing"
    code, said = typed(gw.db, "passwd", "care.cli", "--temporary", answers=(TEMPORARY, TEMPORARY))
    assert code == 0 and TEMPORARY not in said, said
    signed_in = log_in(http, "care.cli", TEMPORARY)
    assert signed_in.json()["user"]["must_change_password"] is True
    assert http.get("/api/v1/patients", headers=bearer(signed_in)).status_code == 403
    details = [e["detail"] for e in audited(http, user_id) if e["action"] == "user.password_reset"]
    assert details == ["care.cli; 1 sessions ended", "care.cli; must change it at next sign-in; 2 sessions ended"]
    verified = subprocess.run(
        [sys.executable, "-m", "burnedge.cli", "--db", str(gw.db), "audit", "verify"],
        capture_output=True,
        text=True,
        cwd=REPO,
        env={**FAST_HASH_ENV, "PATH": ""},
    )
    assert verified.returncode == 0, verified.stdout


def test_users_commands_act_on_the_burn_centers_accounts_with_center(tmp_path):
    gateway_db, center = tmp_path / "gateway.sqlite3", {"BURNEDGE_CENTRAL_DATABASE": str(tmp_path / "center.sqlite3")}
    for name, role in (("center.admin", "admin"), ("dr.burns", "consultant")):
        made = cli(
            gateway_db,
            "add",
            "--username",
            name,
            "--role",
            role,
            "--password-stdin",
            "--center",
            stdin=PASSWORD + "\n",
            env=center,
        )
        assert made.returncode == 0, made.stderr
    assert (
        cli(
            gateway_db,
            "passwd",
            "dr.burns",
            "--temporary",
            "--password-stdin",
            "--center",
            stdin=NEW + "\n",
            env=center,
        ).returncode
        == 0
    )
    assert cli(gateway_db, "disable", "dr.burns", "--center", env=center).returncode == 0
    assert cli(gateway_db, "disable", "center.admin", "--center", env=center).returncode == 4
    listed = {u["username"]: u for u in json.loads(cli(gateway_db, "list", "--center", env=center).stdout)}
    assert set(listed) == {"center.admin", "dr.burns"}
    assert (listed["dr.burns"]["active"], listed["dr.burns"]["must_change_password"]) == (False, True)
    assert json.loads(cli(gateway_db, "list", env=center).stdout) == [], "the clinic's own accounts are apart"


def test_users_add_on_a_terminal_asks_for_the_password_twice(tmp_path):
    db = tmp_path / "typed.sqlite3"
    code, said = typed(db, "add", "--username", "typed", "--role", "nurse", answers=(PASSWORD, PASSWORD + "!"))
    assert code == 2 and "the two passwords differ" in said
    code, said = typed(db, "add", "--username", "typed", "--role", "nurse", answers=(PASSWORD, PASSWORD))
    assert code == 0 and '"username": "typed"' in said and PASSWORD not in said, said
