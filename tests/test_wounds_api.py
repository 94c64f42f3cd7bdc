"""A patient's wounds over the real app: create, list, read, update with If-Match, withdraw, bad bodies."""

from __future__ import annotations

import datetime as dt

import pytest

from base.storage import audit
from harness.bodies import encounter_body, now, patient_body, wound_body
from schemas.ids import uuid7

PROBLEM = "application/problem+json"


@pytest.fixture
def clin(auth):
    return auth["clinician"]


@pytest.fixture
def patient(client, clin) -> dict:
    body = patient_body()
    assert client.post("/api/v1/patients", json=body, headers=clin).status_code == 201
    return body


def _create(client, headers, body: dict):
    return client.post(f"/api/v1/patients/{body['patient_id']}/wounds", json=body, headers=headers)


def test_a_wound_is_created_read_listed_and_audited(client, clin, services, patient):
    older = encounter_body(patient["id"], injury_hours_ago=72)
    older["time_of_arrival"] = (now() - dt.timedelta(hours=70)).isoformat()
    recent = encounter_body(patient["id"], injury_hours_ago=5)
    for enc in (recent, older):
        assert client.post("/api/v1/encounters", json=enc, headers=clin).status_code == 201
    body = wound_body(patient["id"])
    created = _create(client, clin, body)
    assert created.status_code == 201 and created.headers["etag"] == '"1"'
    record = created.json()
    assert record["meta"]["kind"] == "wound" and record["data"]["state"] == "open"
    # Left out, the time of injury comes from the most recent encounter that records one.
    assert dt.datetime.fromisoformat(record["data"]["time_of_injury"]) == dt.datetime.fromisoformat(
        recent["time_of_injury"]
    )
    assert _create(client, clin, body).status_code == 200  # a retry answers the stored wound
    read = client.get(f"/api/v1/wounds/{body['id']}", headers=clin)
    assert read.status_code == 200 and read.json() == record
    second = wound_body(patient["id"], regions=["trunk_anterior"], label="chest", side="midline")
    assert _create(client, clin, second).status_code == 201
    listed = client.get(f"/api/v1/patients/{patient['id']}/wounds", headers=clin).json()
    assert [w["data"]["label"] for w in listed] == ["left forearm", "chest"]
    entries = [e for e in audit.entries(services.db.connection()) if e.kind == "wound"]
    assert [(e.action, e.record_id) for e in entries] == [
        ("record.create", body["id"]),
        ("record.create", second["id"]),
    ]


def test_a_given_time_of_injury_is_kept_and_none_is_left_without_an_encounter(client, clin, patient):
    bare = _create(client, clin, wound_body(patient["id"])).json()
    assert bare["data"]["time_of_injury"] is None
    injured = (now() - dt.timedelta(days=2)).isoformat()
    kept = _create(client, clin, wound_body(patient["id"], time_of_injury=injured)).json()
    assert dt.datetime.fromisoformat(kept["data"]["time_of_injury"]) == dt.datetime.fromisoformat(injured)


def test_update_needs_if_match_and_a_stale_version_is_412(client, clin, patient):
    body = wound_body(patient["id"])
    _create(client, clin, body)
    url = f"/api/v1/wounds/{body['id']}"
    healed = {**body, "state": "healed", "state_date": now().date().isoformat()}
    assert client.put(url, json=healed, headers=clin).status_code == 428
    ok = client.put(url, json=healed, headers={**clin, "If-Match": '"1"'})
    assert ok.status_code == 200 and ok.headers["etag"] == '"2"' and ok.json()["data"]["state"] == "healed"
    stale = client.put(url, json={**body, "notes": "dressing changed"}, headers={**clin, "If-Match": '"1"'})
    assert stale.status_code == 412 and stale.json()["current"]["meta"]["version"] == 2
    history = client.get(url + "/history", headers=clin).json()
    assert history["kind"] == "wound" and [v["data"]["state"] for v in history["versions"]] == ["open", "healed"]
    other = patient_body()
    client.post("/api/v1/patients", json=other, headers=clin)
    moved = client.put(url, json={**healed, "patient_id": other["id"]}, headers={**clin, "If-Match": '"2"'})
    assert moved.status_code == 422 and "cannot move to another patient" in moved.json()["detail"]


def test_withdrawing_needs_a_reason_and_hides_the_wound_from_the_list(client, clin, patient):
    body = wound_body(patient["id"])
    _create(client, clin, body)
    url = f"/api/v1/wounds/{body['id']}"
    assert client.delete(url, headers={**clin, "If-Match": '"1"'}).status_code == 400  # no reason
    gone = client.delete(url, params={"reason": "charted twice"}, headers={**clin, "If-Match": '"1"'})
    assert gone.status_code == 200 and gone.json()["meta"]["deleted"] is True
    assert gone.json()["meta"]["delete_reason"] == "charted twice"
    wounds = f"/api/v1/patients/{patient['id']}/wounds"
    assert client.get(wounds, headers=clin).json() == []
    assert len(client.get(wounds, params={"include_deleted": True}, headers=clin).json()) == 1
    restored = client.put(url, json=body, headers={**clin, "If-Match": '"2"'})
    assert restored.status_code == 200 and restored.json()["meta"]["deleted"] is False


@pytest.mark.parametrize(
    "change, status, field, words",
    [
        ({"regions": []}, 422, "$.regions", "at least one"),
        ({"regions": ["genitalia", "genitalia"]}, 422, "$.regions[1]", "listed twice"),
        ({"label": ""}, 400, "$.label", "length >= 1"),
        ({"state": "healed"}, 422, "$.state_date", "a wound whose state is healed needs state_date"),
        ({"state": "closed_other"}, 422, "$.state_date", "closed by another means needs state_date"),
        ({"state_date": "2026-01-02"}, 422, "$.state_date", "an open wound has no state date"),
        ({"state": "grafted", "state_date": "2999-01-01"}, 422, "$.state_date", "in the future"),
        ({"time_of_injury": "2999-01-01T00:00:00+00:00"}, 422, "$.time_of_injury", "in the future"),
        ({"side": "upside"}, 400, "$.side", "Invalid enum value"),
    ],
)
def test_bad_bodies_are_refused_with_the_field_and_store_nothing(client, clin, patient, change, status, field, words):
    r = _create(client, clin, wound_body(patient["id"], **change))
    assert r.status_code == status and r.headers["content-type"].startswith(PROBLEM)
    problem = r.json()["errors"][0]
    assert problem["field"] == field and words in problem["message"]
    assert client.get(f"/api/v1/patients/{patient['id']}/wounds", headers=clin).json() == []


def test_an_unknown_or_withdrawn_patient_gets_no_wound(client, clin, patient):
    unknown = wound_body(uuid7())
    r = _create(client, clin, unknown)
    assert r.status_code == 404 and "no patient" in r.json()["detail"]
    assert client.get(f"/api/v1/patients/{unknown['patient_id']}/wounds", headers=clin).status_code == 404
    elsewhere = client.post(f"/api/v1/patients/{patient['id']}/wounds", json=unknown, headers=clin)
    assert elsewhere.status_code == 422 and elsewhere.json()["errors"][0]["field"] == "$.patient_id"
    url = f"/api/v1/patients/{patient['id']}"
    client.delete(url, params={"reason": "duplicate"}, headers={**clin, "If-Match": '"1"'})
    refused = _create(client, clin, wound_body(patient["id"]))
    assert refused.status_code == 422 and "was withdrawn" in refused.json()["detail"]
    assert client.get(f"/api/v1/wounds/{uuid7()}", headers=clin).status_code == 404
