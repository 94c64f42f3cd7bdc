"""A bounded schema fuzz: every operation the gateway publishes, as a clinician and as an admin, against a real
gateway process. Each answer must be no 5xx, and its status, content type and body as the published OpenAPI says.

Every failure is collected (once per operation, role, check and status) and reported together, so one run shows
every problem. Generation is derandomized: the same schema gives the same requests.
"""

from __future__ import annotations

import subprocess
import sys
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field

import httpx
import pytest
import requests
import schemathesis
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis.errors import Unsatisfiable
from schemathesis import GenerationMode
from schemathesis.checks import not_a_server_error
from schemathesis.core.failures import FailureGroup
from schemathesis.specs.openapi.checks import (
    content_type_conformance,
    response_schema_conformance,
    status_code_conformance,
)

from base.web.errors import TUS_PATH
from harness.bodies import encounter_body, patient_body
from harness.processes import PASSWORD, REPO, add_user_cli
from schemas.capture import TUS_VERSION

pytestmark = pytest.mark.server

CHECKS = [not_a_server_error, status_code_conformance, content_type_conformance, response_schema_conformance]
ROLES = ("clinician", "admin")
# Examples per operation and role. Positive cases are valid requests (random IDs, mostly 404s); "known" are valid
# requests for a patient and an encounter that exist, so the success answers are checked too; negative ones break
# the schema (400s). About 3,800 requests, under a minute on 2 cores (the suite as a whole must stay under 25 min).
EXAMPLES = {"positive": 8, "known": 15, "negative": 12}
# Logging out ends the session the other operations use: it runs last.
LAST = "POST /api/v1/auth/logout"


@dataclass
class Findings:
    by_key: dict[tuple, str] = field(default_factory=dict)
    counts: dict[tuple, int] = field(default_factory=dict)
    requests: int = 0
    statuses: Counter = field(default_factory=Counter)
    operations: set[str] = field(default_factory=set)

    def add(self, key: tuple, report: Callable[[], str]) -> None:
        if key not in self.by_key:
            self.by_key[key] = report()
        self.counts[key] = self.counts.get(key, 0) + 1

    def summary(self) -> str:
        parts = [f"{len(self.by_key)} distinct failures in {self.requests} requests:"]
        parts += [
            f"  {op} as {role}: {title} (status {status}, {self.counts[op, role, title, status]}x)"
            for op, role, title, status in self.by_key
        ]
        for key, text in self.by_key.items():
            parts.append(f"\n=== {key[0]} as {key[1]} ({self.counts[key]}x): {text}")
        return "\n".join(parts)


def _login(url: str, username: str) -> dict[str, str]:
    r = httpx.post(url + "/api/v1/auth/login", json={"username": username, "password": PASSWORD}, timeout=10)
    assert r.status_code == 200, r.text
    return {"Authorization": f"Bearer {r.json()['access_token']}"}


def _seed(url: str, headers: dict[str, str]) -> dict[str, str]:
    """A patient with an encounter, so that requests naming them reach the handlers' success paths."""
    p = patient_body()
    e = encounter_body(p["id"])
    with httpx.Client(base_url=url, headers=headers, timeout=10) as http:
        assert http.post("/api/v1/patients", json=p).status_code == 201
        assert http.post("/api/v1/encounters", json=e).status_code == 201
    return {"patient_id": p["id"], "encounter_id": e["id"]}


def _fuzz(operation, role: str, headers: dict[str, str], mode: str, known: dict[str, str], findings: Findings):
    path_names = {p.name for p in operation.path_parameters}
    fixed = {k: v for k, v in known.items() if k in path_names} if mode == "known" else None
    if mode == "known" and not fixed:
        return
    if operation.path.startswith(TUS_PATH) and mode != "negative":
        # tus clients send this on every request; without it (the negative cases) every answer is 412.
        headers = {**headers, "Tus-Resumable": TUS_VERSION}
    preconditions = None
    if mode == "known":
        # Preconditions that can hold for the seeded records (create a part, edit version 1), so that writes get
        # past 428 and 422 to their success and 412 answers.
        names = {p.name for p in operation.headers}
        preconditions = {"If-None-Match": "*"} if "If-None-Match" in names else None
        preconditions = {"If-Match": '"1"'} if preconditions is None and "If-Match" in names else preconditions
    generation = GenerationMode.NEGATIVE if mode == "negative" else GenerationMode.POSITIVE
    strategy = operation.as_strategy(generation_mode=generation, path_parameters=fixed, headers=preconditions)
    session = requests.Session()

    @settings(
        max_examples=EXAMPLES[mode],
        derandomize=True,
        database=None,
        deadline=None,
        phases=[Phase.explicit, Phase.generate],
        suppress_health_check=list(HealthCheck),
    )
    @given(case=strategy)
    def run(case) -> None:
        findings.requests += 1
        findings.operations.add(operation.label)
        try:
            response = case.call(session=session, headers=headers, timeout=30)
        except requests.RequestException as exc:
            findings.add(
                (operation.label, role, "transport", type(exc).__name__),
                lambda e=exc: f"no answer: {e!r}\n{case.as_curl_command(headers=headers)}",
            )
            return
        findings.statuses[response.status_code] += 1
        try:
            case.validate_response(response, checks=CHECKS, headers=headers)
        except FailureGroup as group:
            for failure in group.exceptions:
                key = (operation.label, role, failure.title, response.status_code)
                findings.add(key, lambda g=group: f"{mode}\n{g.message}")

    try:
        run()
    except Unsatisfiable:
        pass  # nothing to break: an operation without parameters or body has no negative cases


def test_every_operation_answers_as_the_published_schema_says(gateway_process):
    for role in ROLES:
        add_user_cli(gateway_process.db, role, role)
    # Site keys, so that sending a case to the burn center gets past "this site has no keys" (a true 503) and is queued.
    subprocess.run(
        [
            sys.executable,
            "-m",
            "burnedge.cli",
            "--db",
            str(gateway_process.db),
            "keys",
            "init",
            "--site-id",
            "clinic-fuzz",
            "--name",
            "Fuzz clinic",
        ],
        check=True,
        capture_output=True,
        cwd=REPO,
    )
    # The fuzz sends many wrong passwords from one address; the throttle (tested in test_auth) would lock out the
    # logins the fuzz itself needs.
    gateway_process.env = {"BURNEDGE_SECURITY_LOGIN_FREE_FAILURES": "1000000"}
    gw = gateway_process.start()
    tokens = {role: _login(gw.url, role) for role in ROLES}
    known = _seed(gw.url, tokens["clinician"])
    schema = schemathesis.openapi.from_url(gw.url + "/schema/openapi.json")
    operations = sorted((op.ok() for op in schema.get_all_operations()), key=lambda op: op.label == LAST)
    findings = Findings()
    started = time.monotonic()
    for operation in operations:
        for role in ROLES:
            for mode in EXAMPLES:
                _fuzz(operation, role, tokens[role], mode, known, findings)
    elapsed = time.monotonic() - started
    statuses = sorted(findings.statuses.items())
    print(f"schema fuzz: {len(operations)} operations, {findings.requests} requests in {elapsed:.0f} s: {statuses}")
    assert gw.proc.poll() is None, "the gateway died during the fuzz"
    assert findings.operations == {op.label for op in operations}, "some operations were never called"
    assert not findings.by_key, findings.summary()
