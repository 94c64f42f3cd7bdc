"""Wounds and who may write them; wounds in the phones' change feed and batched push."""

from __future__ import annotations

import pytest

from harness.bodies import encounter_body, patient_body, wound_body
from schemas.ids import uuid7


@pytest.fixture
def patient(client, auth) -> dict:
    body = patient_body()
    assert client.post("/api/v1/patients", json=body, headers=auth["clinician"]).status_code == 201
    return body


def _mutation(record_id: str, op: str, data: dict | None = None, base: int | None = None, **extra) -> dict:
    m = {"mutation_id": uuid7(), "kind": "wound", "id": record_id, "op": op, **extra}
    if data is not None:
        m["data"] = data
    if base is not None:
        m["base_version"] = base
    return m


def test_nurses_and_clinicians_write_wounds_consultants_and_admins_do_not(client, auth, patient):
    url = f"/api/v1/patients/{patient['id']}/wounds"
    by_nurse = wound_body(patient["id"])
    assert client.post(url, json=by_nurse, headers=auth["nurse"]).status_code == 201
    refused = client.post(url, json=wound_body(patient["id"]), headers=auth["consultant"])
    assert refused.status_code == 403 and "consultant may not write wound records" in refused.json()["detail"]
    assert client.post(url, json=wound_body(patient["id"]), headers=auth["admin"]).status_code == 403
    wound_url = f"/api/v1/wounds/{by_nurse['id']}"
    edit = {**by_nurse, "notes": "blisters deroofed"}
    assert client.put(wound_url, json=edit, headers={**auth["consultant"], "If-Match": '"1"'}).status_code == 403
    assert client.get(wound_url, headers=auth["consultant"]).status_code == 200  # consultants read
    assert client.get(wound_url, headers=auth["admin"]).status_code == 403  # administrators do not
    # As for encounters, only a clinician withdraws.
    reason = {"reason": "wrong patient"}
    assert client.delete(wound_url, params=reason, headers={**auth["nurse"], "If-Match": '"1"'}).status_code == 403
    assert client.delete(wound_url, params=reason, headers={**auth["clinician"], "If-Match": '"1"'}).status_code == 200


def test_the_change_feed_shows_wounds_and_a_push_creates_updates_and_withdraws_one(client, auth, patient):
    phone = auth["clinician"]
    encounter = encounter_body(patient["id"])
    client.post("/api/v1/encounters", json=encounter, headers=phone)
    online = wound_body(patient["id"])
    client.post(f"/api/v1/patients/{patient['id']}/wounds", json=online, headers=auth["nurse"])
    feed = client.get("/api/v1/sync/changes", params={"since": 0}, headers=phone).json()
    assert [c["meta"]["id"] for c in feed["changes"] if c["meta"]["kind"] == "wound"] == [online["id"]]

    pushed = wound_body(patient["id"], regions=["thigh_right_anterior"], label="right thigh", side="right")
    bad = wound_body(patient["id"], state="grafted")  # no state_date
    healed = {**online, "state": "healing", "state_date": encounter["time_of_arrival"][:10]}
    queue = [
        _mutation(pushed["id"], "create", pushed),
        _mutation(bad["id"], "create", bad),
        _mutation(online["id"], "update", healed, base=1),
    ]
    r = client.post("/api/v1/sync/push", json={"mutations": queue}, headers=phone).json()
    assert [x["status"] for x in r["results"]] == ["applied", "rejected", "applied"]
    assert "needs state_date" in r["results"][1]["error"]
    stored = client.get(f"/api/v1/wounds/{pushed['id']}", headers=phone).json()
    # The push passes the same checks and gets the same default: the encounter's time of injury.
    assert stored["data"]["time_of_injury"] is not None and stored["meta"]["updated_by"] == "clinician"
    again = client.post("/api/v1/sync/push", json={"mutations": queue}, headers=phone).json()
    assert [x["replayed"] for x in again["results"]] == [True, False, True]

    withdraw = _mutation(pushed["id"], "delete", base=1, reason="photographed as part of the thigh wound")
    assert client.post("/api/v1/sync/push", json={"mutations": [withdraw]}, headers=phone).json()["applied"] == 1
    later = client.get("/api/v1/sync/changes", params={"since": feed["next_cursor"]}, headers=phone).json()
    wounds = [(c["meta"]["id"], c["meta"]["version"], c["meta"]["deleted"]) for c in later["changes"]]
    assert wounds == [(pushed["id"], 1, False), (online["id"], 2, False), (pushed["id"], 2, True)]
    listed = client.get(f"/api/v1/patients/{patient['id']}/wounds", params={"include_deleted": True}, headers=phone)
    assert {w["meta"]["id"] for w in listed.json()} == {online["id"], pushed["id"]}


def test_a_consultant_cannot_push_a_wound(client, auth, patient):
    m = _mutation(uuid7(), "create", wound_body(patient["id"]))
    r = client.post("/api/v1/sync/push", json={"mutations": [m]}, headers=auth["consultant"]).json()
    assert r["rejected"] == 1 and "may not write wound records" in r["results"][0]["error"]
