"""What an attacker on the clinic's Wi-Fi tried (issue 15), against a real gateway process on loopback."""

from __future__ import annotations

import importlib
import pkgutil
import re
import typing
from urllib.parse import quote

import httpx
import msgspec
import pytest

import schemas
from harness.bodies import encounter_body, patient_body
from harness.processes import PASSWORD, add_user_cli
from harness.sites import wait_for
from schemas.accounts import Username
from schemas.base import Id
from schemas.ids import uuid7
from schemas.transfer import Sha256, SiteId

pytestmark = pytest.mark.server

NESTED = b"[" * 5000 + b"]" * 5000
"""Deep enough to exhaust the JSON decoder's recursion limit wherever it runs."""


@pytest.fixture
def served(gateway_process):
    add_user_cli(gateway_process.db, "clinician", "clinician")
    gw = gateway_process.start()
    with httpx.Client(base_url=gw.url, timeout=20) as http:
        token = http.post("/api/v1/auth/login", json={"username": "clinician", "password": PASSWORD}).json()
        http.headers["Authorization"] = f"Bearer {token['access_token']}"
        yield gw, http


def test_deeply_nested_json_is_a_400_with_one_warning_line_on_anonymous_and_authenticated_routes(served):
    gw, http = served
    anonymous = {"content-type": "application/json", "Authorization": ""}
    for path, headers in [
        ("/api/v1/auth/login", anonymous),
        ("/api/v1/auth/pair", anonymous),
        ("/api/v1/patients", {}),
        ("/api/v1/sync/push", {}),
    ]:
        r = http.post(path, content=NESTED, headers={"content-type": "application/json", **headers})
        assert r.status_code == 400, (path, r.text)
        assert r.headers["content-type"].startswith("application/problem+json")
        assert "nested too deeply" in r.json()["detail"]
    assert http.get("/health").status_code == 200  # still serving
    # The server's log lines go through a queue (Litestar's logging config): they may land just after the answer.
    wait_for(lambda: gw.log.read_text().count("nested too deeply") >= 4, 10, "the four warning lines")
    log = gw.log.read_text()
    assert log.count("nested too deeply") == 4 and "Traceback" not in log and "RecursionError" not in log


VARIANTS = {
    "newline": lambda i: i + "\n",
    "space": lambda i: " " + i,
    "tab": lambda i: i + "\t",
    "upper-case": str.upper,
    "no-dashes": lambda i: i.replace("-", ""),
}


@pytest.mark.parametrize("variant", VARIANTS.values(), ids=VARIANTS.keys())
def test_an_id_that_is_not_exactly_canonical_is_refused_in_bodies_and_paths(served, variant):
    _, http = served
    patient_id, encounter_id = uuid7(), uuid7()
    assert http.post("/api/v1/patients", json=patient_body(variant(patient_id))).status_code == 400
    assert http.post("/api/v1/patients", json=patient_body(patient_id)).status_code == 201
    assert http.get(f"/api/v1/patients/{patient_id}").status_code == 200
    r = http.get(f"/api/v1/patients/{quote(variant(patient_id), safe='')}")
    assert r.status_code == 400, r.text
    assert http.post("/api/v1/encounters", json=encounter_body(patient_id, variant(encounter_id))).status_code == 400
    assert http.post("/api/v1/encounters", json=encounter_body(variant(patient_id))).status_code == 400
    assert http.post("/api/v1/encounters", json=encounter_body(patient_id, encounter_id)).status_code == 201
    r = http.get(f"/api/v1/encounters/{quote(variant(encounter_id), safe='')}")
    assert r.status_code == 400, r.text
    assert [p["meta"]["id"] for p in http.get("/api/v1/patients").json()] == [patient_id]


def test_transfers_of_an_unknown_or_malformed_encounter_are_404_and_400_before_anything_about_keys(served):
    _, http = served
    r = http.post(f"/api/v1/encounters/{uuid7()}/transfers")
    assert r.status_code == 404 and "no encounter" in r.json()["detail"]
    assert http.post("/api/v1/encounters/not-a-uuid/transfers").status_code == 400
    assert http.get(f"/api/v1/encounters/{uuid7()}/assets").status_code == 404
    patient = patient_body()
    http.post("/api/v1/patients", json=patient)
    encounter = encounter_body(patient["id"])
    http.post("/api/v1/encounters", json=encounter)
    r = http.post(f"/api/v1/encounters/{encounter['id']}/transfers")
    assert r.status_code == 503 and "keys" in r.json()["detail"]  # a real encounter: now the missing keys matter


@pytest.mark.parametrize(
    "pattern_type, good", [(Id, uuid7()), (Username, "nurse.amani"), (SiteId, "clinic-kasese"), (Sha256, "ab" * 32)]
)
def test_string_patterns_match_whole_values_only(pattern_type, good):
    assert msgspec.convert(good, pattern_type) == good
    for bad in (good + "\n", "\n" + good, good + " ", " " + good):
        with pytest.raises(msgspec.ValidationError):
            msgspec.convert(bad, pattern_type)


def test_every_pattern_in_the_schemas_is_anchored_at_both_ends():
    """msgspec searches patterns: `^...$` lets a trailing newline through, so every pattern must use \\A...\\Z."""
    found = {}
    for module_info in pkgutil.iter_modules(schemas.__path__):
        module = importlib.import_module(f"schemas.{module_info.name}")
        for name, value in vars(module).items():
            for meta in _metas(value):
                if meta.pattern is not None:
                    found[f"{module_info.name}.{name}"] = meta.pattern
    assert len(found) >= 4, found
    loose = {name: p for name, p in found.items() if not (p.startswith(r"\A") and p.endswith(r"\Z"))}
    assert not loose, f"patterns not anchored with \\A...\\Z: {loose}"
    for pattern in found.values():
        re.compile(pattern)


def _metas(value) -> list[msgspec.Meta]:
    if typing.get_origin(value) is typing.Annotated:
        return [m for m in typing.get_args(value)[1:] if isinstance(m, msgspec.Meta)]
    return []
