"""Offline-first phone sync: a week offline, 200 queued mutations, conflicts, retries."""

from __future__ import annotations

import datetime as dt

import pytest

from harness.bodies import encounter_body, now, patient_body
from schemas.ids import uuid7

WEEK_AGO = now() - dt.timedelta(days=7)


def _m(kind: str, record_id: str, op: str, data: dict | None = None, base: int | None = None, **extra) -> dict:
    m = {"mutation_id": uuid7(), "kind": kind, "id": record_id, "op": op, "client_time": WEEK_AGO.isoformat()}
    if data is not None:
        m["data"] = data
    if base is not None:
        m["base_version"] = base
    m.update(extra)
    return m


def _pull_all(client, headers, since: int, page: int) -> tuple[dict, int]:
    """What a phone holds after pulling the feed in pages: (kind, id) -> latest record."""
    state: dict = {}
    cursor = since
    while True:
        r = client.get("/api/v1/sync/changes", params={"since": cursor, "limit": page}, headers=headers).json()
        for rec in r["changes"]:
            key = (rec["meta"]["kind"], rec["meta"]["id"])
            if key not in state or state[key]["meta"]["version"] < rec["meta"]["version"]:
                state[key] = rec
        assert r["next_cursor"] >= cursor
        cursor = r["next_cursor"]
        if not r["has_more"]:
            return state, cursor


def _server_heads(services) -> dict:
    rows = services.db.connection().execute("SELECT kind, id, seq FROM record_heads").fetchall()
    return {(r["kind"], r["id"]): r["seq"] for r in rows}


@pytest.fixture
def week_offline(client, auth):
    """10 patients the phone had pulled, then edits made at the clinic while the phone was away."""
    online, phone = auth["nurse"], auth["clinician"]  # only a clinician may withdraw (the queue does)
    patients = [patient_body(given_name=f"P{i}") for i in range(10)]
    for p in patients:
        assert client.post("/api/v1/patients", json=p, headers=online).status_code == 201
    _, cursor = _pull_all(client, phone, 0, 50)
    for p in patients[:5]:  # edited at the clinic during the week
        r = client.put(
            f"/api/v1/patients/{p['id']}", json={**p, "weight_kg": 80.0}, headers={**online, "If-Match": "1"}
        )
        assert r.status_code == 200
    return patients, cursor


def _queue(patients: list[dict]) -> tuple[list[dict], dict]:
    """200 mutations a phone queued offline, in the order it made them."""
    queue: list[dict] = []
    new_patients = [patient_body(given_name=f"N{i}") for i in range(40)]
    encounters = [encounter_body(p["id"], injury_hours_ago=2) for p in new_patients]
    queue += [_m("patient", p["id"], "create", p) for p in new_patients]
    queue += [_m("encounter", e["id"], "create", e) for e in encounters]
    for e in encounters:
        intake = {"encounter_id": e["id"], "history_of_present_illness": "scald"}
        queue.append(_m("intake", e["id"], "create", intake))
    for e in encounters:  # the phone edited its own intake again before syncing
        intake = {"encounter_id": e["id"], "history_of_present_illness": "scald, hot tea, 20 s cooling"}
        queue.append(_m("intake", e["id"], "update", intake, base=1))
    # edits of patients the clinic also edited (5 conflicts) or left alone (5 applied)
    queue += [_m("patient", p["id"], "update", {**p, "height_cm": 160.0}, base=1) for p in patients]
    for e in encounters[:20]:
        queue.append(_m("mechanism", e["id"], "create", {"encounter_id": e["id"], "type": "scald"}))
    queue += [
        _m("mechanism", e["id"], "delete", base=1, reason="entered on the wrong encounter") for e in encounters[:10]
    ]
    assert len(queue) == 200
    return queue, {"patients": new_patients, "encounters": encounters}


def test_a_week_offline_then_200_mutations_pushed_three_times(client, auth, services, week_offline):
    patients, cursor = week_offline
    phone, online = auth["clinician"], auth["nurse"]
    queue, made = _queue(patients)

    first = client.post("/api/v1/sync/push", json={"mutations": queue}, headers=phone)
    assert first.status_code == 200, first.text
    body = first.json()
    assert (body["applied"], body["conflicts"], body["rejected"]) == (195, 5, 0)
    conflicts = [r for r in body["results"] if r["status"] == "conflict"]
    assert {c["current"]["data"]["id"] for c in conflicts} == {p["id"] for p in patients[:5]}
    assert all(c["current"]["meta"]["version"] == 2 and "version 2" in c["error"] for c in conflicts)

    versions_after_first = services.db.connection().execute("SELECT COUNT(*) FROM record_versions").fetchone()[0]
    for _ in range(2):  # the answer was lost on bad Wi-Fi: the phone retries the same batch
        again = client.post("/api/v1/sync/push", json={"mutations": queue}, headers=phone).json()
        assert (again["applied"], again["conflicts"], again["rejected"]) == (195, 5, 0)
        assert all(r["replayed"] for r in again["results"] if r["status"] == "applied")
        assert [r["version"] for r in again["results"]] == [r["version"] for r in body["results"]]
    count = services.db.connection().execute("SELECT COUNT(*) FROM record_versions").fetchone()[0]
    assert count == versions_after_first, "a retried batch must not write anything"

    conn = services.db.connection()
    assert conn.execute("SELECT COUNT(*) FROM record_heads WHERE kind = 'patient'").fetchone()[0] == 50
    assert conn.execute("SELECT COUNT(*) FROM record_heads WHERE kind = 'encounter'").fetchone()[0] == 40
    for e in made["encounters"]:
        intake = client.get(f"/api/v1/encounters/{e['id']}/intake", headers=online).json()
        assert intake["meta"]["version"] == 2 and "20 s cooling" in intake["data"]["history_of_present_illness"]
    withdrawn = conn.execute("SELECT COUNT(*) FROM record_heads WHERE kind = 'mechanism' AND deleted = 1").fetchone()[0]
    assert withdrawn == 10
    # the clinic's edits were not overwritten; the untouched patients took the phone's edit
    for p in patients[:5]:
        data = client.get(f"/api/v1/patients/{p['id']}", headers=online).json()["data"]
        assert data["weight_kg"] == 80.0 and data["height_cm"] == 175.0
    for p in patients[5:]:
        data = client.get(f"/api/v1/patients/{p['id']}", headers=online).json()["data"]
        assert data["height_cm"] == 160.0

    # the phone merges each conflict onto the current version and pushes again
    merged = [
        _m(
            "patient",
            c["current"]["meta"]["id"],
            "update",
            {**c["current"]["data"], "height_cm": 160.0},
            base=c["current"]["meta"]["version"],
        )
        for c in conflicts
    ]
    resolved = client.post("/api/v1/sync/push", json={"mutations": merged}, headers=phone).json()
    assert resolved["applied"] == 5
    for p in patients[:5]:
        data = client.get(f"/api/v1/patients/{p['id']}", headers=online).json()["data"]
        assert (data["weight_kg"], data["height_cm"]) == (80.0, 160.0)

    # nothing lost: the phone's pull from its old cursor, and a new phone's from zero, match the gateway
    heads = _server_heads(services)
    state, _ = _pull_all(client, phone, cursor, 37)
    fresh, _ = _pull_all(client, online, 0, 64)
    assert {k: v["meta"]["seq"] for k, v in fresh.items()} == heads
    changed_since_cursor = {k: s for k, s in heads.items() if s > cursor}
    assert {k: v["meta"]["seq"] for k, v in state.items()} == changed_since_cursor


def test_push_rejects_bad_items_without_undoing_good_ones(client, auth, services):
    phone = auth["clinician"]
    good = patient_body()
    bad_weight = patient_body(weight_kg=-1)
    orphan = encounter_body(uuid7())
    no_base = _m("patient", good["id"], "update", good)
    queue = [
        _m("patient", good["id"], "create", good),
        _m("patient", bad_weight["id"], "create", bad_weight),
        _m("encounter", orphan["id"], "create", orphan),
        no_base,
        _m("assessment", good["id"], "create", {}),
    ]
    r = client.post("/api/v1/sync/push", json={"mutations": queue}, headers=phone).json()
    assert [x["status"] for x in r["results"]] == ["applied", "rejected", "rejected", "rejected", "rejected"]
    assert "weight_kg" in r["results"][1]["error"]
    assert "base_version" in r["results"][3]["error"]
    assert services.db.connection().execute("SELECT COUNT(*) FROM record_versions").fetchone()[0] == 1


def test_a_rejected_item_can_succeed_later_when_its_parent_arrives(client, auth):
    phone = auth["clinician"]
    p = patient_body()
    e = encounter_body(p["id"])
    enc = _m("encounter", e["id"], "create", e)
    assert client.post("/api/v1/sync/push", json={"mutations": [enc]}, headers=phone).json()["rejected"] == 1
    both = [_m("patient", p["id"], "create", p), enc]
    assert client.post("/api/v1/sync/push", json={"mutations": both}, headers=phone).json()["applied"] == 2


def test_push_body_must_be_well_formed(client, auth, services):
    phone = auth["clinician"]
    bad = {"mutations": [{"mutation_id": uuid7(), "kind": "weather", "id": uuid7(), "op": "create"}]}
    r = client.post("/api/v1/sync/push", json=bad, headers=phone)
    assert r.status_code == 400 and r.headers["content-type"].startswith("application/problem+json")
    assert client.get("/api/v1/sync/changes", params={"since": -1}, headers=phone).status_code == 400


def test_a_reused_mutation_id_with_other_content_is_rejected_not_dropped(client, auth, services):
    phone = auth["clinician"]
    first = patient_body()
    m = _m("patient", first["id"], "create", first)
    assert client.post("/api/v1/sync/push", json={"mutations": [m]}, headers=phone).json()["applied"] == 1
    second = patient_body()
    reused = {**m, "id": second["id"], "data": second}
    r = client.post("/api/v1/sync/push", json={"mutations": [reused]}, headers=phone).json()
    assert r["results"][0]["status"] == "rejected" and "different change" in r["results"][0]["error"]
    assert client.get(f"/api/v1/patients/{second['id']}", headers=phone).status_code == 404
    # the same mutation with only the phone's clock changed is still the same mutation
    same = {**m, "client_time": now().isoformat()}
    assert client.post("/api/v1/sync/push", json={"mutations": [same]}, headers=phone).json()["results"][0]["replayed"]


def test_a_replay_is_checked_against_the_callers_role(client, auth):
    p = patient_body()
    m = _m("patient", p["id"], "create", p)
    assert client.post("/api/v1/sync/push", json={"mutations": [m]}, headers=auth["clinician"]).json()["applied"] == 1
    r = client.post("/api/v1/sync/push", json={"mutations": [m]}, headers=auth["consultant"]).json()
    assert r["results"][0]["status"] == "rejected"
