"""The gateway as a real process: uvicorn on loopback, spoken to over real HTTP."""

from __future__ import annotations

import subprocess
import sys

import httpx
import pytest

from harness.bodies import encounter_body, patient_body
from harness.processes import PASSWORD, REPO, add_user_cli

pytestmark = pytest.mark.server


def test_served_gateway_answers_over_loopback_and_keeps_data_across_restarts(gateway_process):
    add_user_cli(gateway_process.db, "clinician", "clinician")
    gw = gateway_process.start()
    with httpx.Client(base_url=gw.url, timeout=10) as http:
        assert http.get("/health").json()["status"] == "ok"
        assert http.get("/api/v1/patients").status_code == 401
        token = http.post("/api/v1/auth/login", json={"username": "clinician", "password": PASSWORD}).json()
        h = {"Authorization": f"Bearer {token['access_token']}"}
        p = patient_body()
        assert http.post("/api/v1/patients", json=p, headers=h).status_code == 201
        e = encounter_body(p["id"])
        assert http.post("/api/v1/encounters", json=e, headers=h).status_code == 201
        bad = http.post(
            "/api/v1/patients", content=b"\xff\xfe not json", headers={**h, "content-type": "application/json"}
        )
        assert bad.status_code == 400
        assert http.get("/schema/openapi.json").json()["info"]["title"] == "burnedge gateway"
    gw.stop()
    gw.start()  # sessions and records survive a restart: they live in the SQLite file
    with httpx.Client(base_url=gw.url, timeout=10) as http:
        r = http.get(f"/api/v1/patients/{p['id']}", headers=h)
        assert r.status_code == 200 and r.headers["etag"] == '"1"'
        assert len(http.get(f"/api/v1/patients/{p['id']}/encounters", headers=h).json()) == 1


def test_a_bad_config_is_a_clear_error(tmp_path):
    cfg = tmp_path / "bad.toml"
    cfg.write_text("[gateway]\nport = 'eighty'\n")
    r = subprocess.run(
        [sys.executable, "-m", "burnedge.cli", "--config", str(cfg), "serve"],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=60,
    )
    assert r.returncode == 2 and "configuration is invalid" in r.stderr
