"""The clinical record over the real app: versions, preconditions, soft delete, bad input."""

from __future__ import annotations

import datetime as dt

import pytest

from harness.bodies import encounter_body, now, patient_body
from schemas.ids import uuid7

PROBLEM = "application/problem+json"


def _count_versions(services) -> int:
    return services.db.connection().execute("SELECT COUNT(*) FROM record_versions").fetchone()[0]


@pytest.fixture
def clin(auth):
    return auth["clinician"]


@pytest.fixture
def patient(client, clin) -> dict:
    body = patient_body()
    assert client.post("/api/v1/patients", json=body, headers=clin).status_code == 201
    return body


@pytest.fixture
def encounter(client, clin, patient) -> dict:
    body = encounter_body(patient["id"])
    assert client.post("/api/v1/encounters", json=body, headers=clin).status_code == 201
    return body


def test_create_is_idempotent_for_the_same_id_and_content(client, clin, services):
    body = patient_body()
    first = client.post("/api/v1/patients", json=body, headers=clin)
    again = client.post("/api/v1/patients", json=body, headers=clin)
    assert (first.status_code, again.status_code) == (201, 200)
    assert first.headers["etag"] == again.headers["etag"] == '"1"'
    assert client.get("/api/v1/patients", headers=clin).json()[0]["data"]["id"] == body["id"]
    assert _count_versions(services) == 1


def test_create_with_a_taken_id_and_other_content_is_a_conflict(client, clin, patient):
    r = client.post("/api/v1/patients", json={**patient, "given_name": "Someone else"}, headers=clin)
    assert r.status_code == 409
    assert r.headers["content-type"].startswith(PROBLEM)
    assert r.json()["current"]["data"]["given_name"] == "Test"


def test_update_needs_if_match_and_rejects_a_stale_version(client, clin, patient):
    url = f"/api/v1/patients/{patient['id']}"
    assert client.put(url, json={**patient, "weight_kg": 71}, headers=clin).status_code == 428
    ok = client.put(url, json={**patient, "weight_kg": 71}, headers={**clin, "If-Match": '"1"'})
    assert ok.status_code == 200 and ok.headers["etag"] == '"2"'
    stale = client.put(url, json={**patient, "weight_kg": 90}, headers={**clin, "If-Match": '"1"'})
    assert stale.status_code == 412
    assert stale.json()["current"]["meta"]["version"] == 2
    assert stale.json()["current"]["data"]["weight_kg"] == 71
    assert client.get(url, headers=clin).json()["data"]["weight_kg"] == 71


def test_a_retried_update_is_answered_without_a_new_version(client, clin, patient):
    url = f"/api/v1/patients/{patient['id']}"
    body = {**patient, "weight_kg": 72}
    first = client.put(url, json=body, headers={**clin, "If-Match": '"1"'})
    retry = client.put(url, json=body, headers={**clin, "If-Match": '"1"'})
    assert first.status_code == retry.status_code == 200
    assert retry.headers["etag"] == '"2"'
    assert len(client.get(url + "/history", headers=clin).json()["versions"]) == 2


def test_history_keeps_every_version_and_delete_is_soft(client, clin, patient):
    url = f"/api/v1/patients/{patient['id']}"
    client.put(url, json={**patient, "weight_kg": 75}, headers={**clin, "If-Match": "1"})
    assert client.delete(url, headers={**clin, "If-Match": '"2"'}).status_code == 400  # no reason given
    gone = client.delete(url, params={"reason": "duplicate registration"}, headers={**clin, "If-Match": '"2"'})
    assert gone.status_code == 200 and gone.json()["meta"]["deleted"] is True
    versions = client.get(url + "/history", headers=clin).json()["versions"]
    assert [v["meta"]["version"] for v in versions] == [1, 2, 3]
    assert [v["data"]["weight_kg"] for v in versions] == [70.0, 75.0, 75.0]
    assert versions[-1]["meta"]["delete_reason"] == "duplicate registration"
    assert client.get("/api/v1/patients", headers=clin).json() == []
    assert len(client.get("/api/v1/patients", params={"include_deleted": True}, headers=clin).json()) == 1
    assert client.put(url, json=patient, headers={**clin, "If-Match": '"2"'}).status_code == 412
    restored = client.put(url, json=patient, headers={**clin, "If-Match": '"3"'})  # restoring the withdrawn version
    assert restored.status_code == 200 and restored.json()["meta"]["deleted"] is False


@pytest.mark.parametrize(
    "mutate, field",
    [
        (lambda b: b.update(weight_kg=0), "$.weight_kg"),
        (lambda b: b.update(weight_kg=401), "$.weight_kg"),
        (lambda b: b.update(weight_kg="seventy"), "$.weight_kg"),
        (lambda b: b.update(height_cm=5), "$.height_cm"),
        (lambda b: b.update(shoe_size=42), "$.shoe_size"),
        (lambda b: b.update(sex="unicorn"), "$.sex"),
        (lambda b: b.update(id="not-an-id"), "$.id"),
    ],
)
def test_bad_fields_are_rejected_with_field_detail_and_store_nothing(client, clin, services, mutate, field):
    body = patient_body()
    mutate(body)
    before = _count_versions(services)
    r = client.post("/api/v1/patients", json=body, headers=clin)
    assert r.status_code == 400
    assert r.headers["content-type"].startswith(PROBLEM)
    assert r.json()["errors"][0]["field"] == field
    assert _count_versions(services) == before


def test_malformed_json_is_a_problem_and_stores_nothing(client, clin, services):
    r = client.post("/api/v1/patients", content=b'{"id": ', headers={**clin, "content-type": "application/json"})
    assert r.status_code == 400 and r.headers["content-type"].startswith(PROBLEM)
    assert _count_versions(services) == 0


def test_encounter_times_are_checked(client, clin, patient, services):
    future = encounter_body(patient["id"])
    future["time_of_injury"] = (now() + dt.timedelta(hours=2)).isoformat()
    r = client.post("/api/v1/encounters", json=future, headers=clin)
    assert r.status_code == 422 and r.json()["errors"][0]["field"] == "$.time_of_injury"
    late = encounter_body(patient["id"], injury_hours_ago=1)
    late["time_of_arrival"] = (now() - dt.timedelta(hours=2)).isoformat()
    assert client.post("/api/v1/encounters", json=late, headers=clin).status_code == 422
    naive = encounter_body(patient["id"])
    naive["time_of_arrival"] = "2026-01-01T10:00:00"
    assert client.post("/api/v1/encounters", json=naive, headers=clin).status_code == 400
    orphan = encounter_body(uuid7())
    assert client.post("/api/v1/encounters", json=orphan, headers=clin).status_code == 404
    assert _count_versions(services) == 1


def _chart(encounter_id: str, entries: list[dict]) -> dict:
    return {"encounter_id": encounter_id, "assessed_at": now().isoformat(), "entries": entries}


def test_writing_the_burn_chart_stores_the_calculators_results_with_their_inputs(client, clin, encounter):
    eid = encounter["id"]
    chart = _chart(
        eid,
        [
            {"region": "trunk_anterior", "fraction": 1.0, "depth": "deep_partial"},
            {"region": "thigh_right_anterior", "fraction": 1.0, "depth": "full_thickness"},
            {"region": "neck_anterior", "fraction": 1.0, "depth": "superficial"},
        ],
    )
    r = client.put(f"/api/v1/encounters/{eid}/burn-chart", json=chart, headers={**clin, "If-None-Match": "*"})
    assert r.status_code == 201
    a = client.get(f"/api/v1/encounters/{eid}/assessment", headers=clin).json()["data"]
    # adult: anterior trunk 13 + half a thigh 9.5 / 2; the superficial neck is excluded
    assert a["tbsa"]["tbsa_percent"] == pytest.approx(17.75)
    assert a["tbsa"]["excluded_superficial_percent"] == pytest.approx(1.0)
    # Parkland 4 x 70 kg x 17.75 % = 4970 mL; 3 h after injury, 2485 mL over the 5 h left of the first 8 h
    assert a["fluids"]["total_24h_ml"] == pytest.approx(4970)
    assert a["fluids"]["rate_now_ml_per_h"] == pytest.approx(497, abs=1)
    assert {"kind": "burn_chart", "id": eid, "version": 1} in a["inputs"]
    assert "Decision support" in a["notice"]
    assert "aba2022.full_thickness" in a["referral"]["current"]["met"]


def test_fluid_given_lowers_the_rate_and_recompute_uses_it(client, clin, encounter):
    eid = encounter["id"]
    chart = _chart(
        eid,
        [
            {"region": "trunk_anterior", "fraction": 1.0, "depth": "deep_partial"},
            {"region": "trunk_posterior", "fraction": 1.0, "depth": "deep_partial"},
        ],
    )
    client.put(f"/api/v1/encounters/{eid}/burn-chart", json=chart, headers={**clin, "If-None-Match": "*"})
    given = {"encounter_id": eid, "fluid_given": [{"volume_ml": 1000, "given_at": now().isoformat()}]}
    r = client.put(f"/api/v1/encounters/{eid}/resuscitation", json=given, headers={**clin, "If-None-Match": "*"})
    assert r.status_code == 201
    a = client.post(f"/api/v1/encounters/{eid}/assessment", headers=clin).json()["data"]
    # 4 x 70 x 26 = 7280 mL; first half 3640 - 1000 given = 2640 mL over the remaining 5 h
    assert a["fluids"]["fluid_given_ml"] == 1000
    assert a["fluids"]["rate_now_ml_per_h"] == pytest.approx(528, abs=1)


def test_an_impossible_chart_is_refused_and_nothing_is_written(client, clin, encounter, services):
    eid = encounter["id"]
    before = _count_versions(services)
    chart = _chart(
        eid,
        [
            {"region": "trunk_anterior", "fraction": 0.7, "depth": "deep_partial"},
            {"region": "trunk_anterior", "fraction": 0.6, "depth": "full_thickness"},
        ],
    )
    r = client.put(f"/api/v1/encounters/{eid}/burn-chart", json=chart, headers={**clin, "If-None-Match": "*"})
    assert r.status_code == 422
    assert "Trunk, front" in r.json()["detail"]
    assert _count_versions(services) == before
    fraction = _chart(eid, [{"region": "trunk_anterior", "fraction": 1.5, "depth": "deep_partial"}])
    r = client.put(f"/api/v1/encounters/{eid}/burn-chart", json=fraction, headers={**clin, "If-None-Match": "*"})
    assert r.status_code == 400 and r.json()["errors"][0]["field"].endswith("fraction")


def test_part_must_match_its_encounter_and_assessment_is_server_only(client, clin, encounter, patient):
    eid = encounter["id"]
    wrong = {"encounter_id": uuid7(), "history_of_present_illness": "x"}
    r = client.put(f"/api/v1/encounters/{eid}/intake", json=wrong, headers={**clin, "If-None-Match": "*"})
    assert r.status_code == 422
    assert client.put(f"/api/v1/encounters/{eid}/assessment", json={}, headers=clin).status_code == 405


def test_full_record_returns_every_part(client, clin, encounter):
    eid = encounter["id"]
    intake = {
        "encounter_id": eid,
        "history_of_present_illness": "scald from a kettle",
        "medications": [{"name": "salbutamol"}],
        "tetanus_status": "up_to_date",
    }
    client.put(f"/api/v1/encounters/{eid}/intake", json=intake, headers={**clin, "If-None-Match": "*"})
    mech = {"encounter_id": eid, "type": "scald", "agent": "boiling water", "duration_s": 3}
    client.put(f"/api/v1/encounters/{eid}/mechanism", json=mech, headers={**clin, "If-None-Match": "*"})
    full = client.get(f"/api/v1/encounters/{eid}/record", headers=clin).json()
    assert full["encounter"]["data"]["id"] == eid
    assert set(full["parts"]) == {"intake", "mechanism", "assessment", "decision_support"}
    assert full["parts"]["intake"]["data"]["medications"] == [{"name": "salbutamol", "dose": None}]


def _put_chart(client, headers, eid, entries, **precondition):
    return client.put(
        f"/api/v1/encounters/{eid}/burn-chart", json=_chart(eid, entries), headers={**headers, **precondition}
    )


TRUNK = [{"region": "trunk_anterior", "fraction": 1.0, "depth": "deep_partial"}]


def test_withdrawing_a_part_recomputes_the_results_without_it(client, clin, encounter):
    eid = encounter["id"]
    _put_chart(client, clin, eid, TRUNK, **{"If-None-Match": "*"})
    assert client.get(f"/api/v1/encounters/{eid}/assessment", headers=clin).json()["data"]["tbsa"] is not None
    r = client.delete(
        f"/api/v1/encounters/{eid}/burn-chart",
        params={"reason": "charted on the wrong patient"},
        headers={**clin, "If-Match": '"1"'},
    )
    assert r.status_code == 200
    a = client.get(f"/api/v1/encounters/{eid}/assessment", headers=clin).json()["data"]
    assert a["tbsa"] is None and a["fluids"] is None
    assert not any(i["kind"] == "burn_chart" for i in a["inputs"])


def test_a_withdrawn_part_is_restored_by_updating_its_withdrawn_version(client, clin, encounter):
    eid = encounter["id"]
    _put_chart(client, clin, eid, TRUNK, **{"If-None-Match": "*"})
    client.delete(
        f"/api/v1/encounters/{eid}/burn-chart", params={"reason": "mistake"}, headers={**clin, "If-Match": "1"}
    )
    again = _put_chart(client, clin, eid, TRUNK, **{"If-None-Match": "*"})
    assert again.status_code == 412 and 'If-Match: "2"' in again.json()["detail"]
    restored = _put_chart(client, clin, eid, TRUNK, **{"If-Match": '"2"'})
    assert restored.status_code == 200
    assert restored.json()["meta"]["version"] == 3 and restored.json()["meta"]["deleted"] is False
    a = client.get(f"/api/v1/encounters/{eid}/assessment", headers=clin).json()["data"]
    assert a["tbsa"]["tbsa_percent"] == pytest.approx(13.0)


def test_if_none_match_on_an_existing_part_is_412(client, clin, encounter):
    eid = encounter["id"]
    assert _put_chart(client, clin, eid, TRUNK, **{"If-None-Match": "*"}).status_code == 201
    other = [{"region": "trunk_posterior", "fraction": 1.0, "depth": "deep_partial"}]
    r = _put_chart(client, clin, eid, other, **{"If-None-Match": "*"})
    assert r.status_code == 412 and r.json()["current"]["data"]["entries"][0]["region"] == "trunk_anterior"
    stale = _put_chart(client, clin, eid, other, **{"If-Match": '"7"'})
    assert stale.status_code == 412 and stale.headers["etag"] == '"1"'


def test_an_encounter_cannot_move_to_another_patient(client, clin, encounter):
    other = patient_body()
    client.post("/api/v1/patients", json=other, headers=clin)
    moved = {**encounter, "patient_id": other["id"]}
    r = client.put(f"/api/v1/encounters/{encounter['id']}", json=moved, headers={**clin, "If-Match": '"1"'})
    assert r.status_code == 422 and r.json()["errors"][0]["field"] == "$.patient_id"


def test_a_withdrawn_patients_encounters_take_no_new_parts(client, clin, patient, encounter):
    client.delete(
        f"/api/v1/patients/{patient['id']}", params={"reason": "duplicate"}, headers={**clin, "If-Match": "1"}
    )
    intake = {"encounter_id": encounter["id"], "history_of_present_illness": "x"}
    r = client.put(f"/api/v1/encounters/{encounter['id']}/intake", json=intake, headers={**clin, "If-None-Match": "*"})
    assert r.status_code == 422 and "withdrawn" in r.json()["detail"]


def test_recomputing_a_withdrawn_encounter_is_refused(client, clin, encounter):
    eid = encounter["id"]
    client.delete(f"/api/v1/encounters/{eid}", params={"reason": "opened twice"}, headers={**clin, "If-Match": "1"})
    assert client.post(f"/api/v1/encounters/{eid}/assessment", headers=clin).status_code == 409


def test_huge_cursors_and_offsets_are_refused_not_crashed(client, clin):
    assert client.get("/api/v1/sync/changes", params={"since": 10**30}, headers=clin).status_code == 400
    assert client.get("/api/v1/patients", params={"offset": 10**30}, headers=clin).status_code == 400
    assert client.get("/api/v1/patients", params={"limit": 10**6}, headers=clin).status_code == 200


def test_times_with_any_utc_offset_are_accepted_and_kept(client, clin, patient):
    e = encounter_body(patient["id"])
    t = (now() - dt.timedelta(hours=1)).astimezone(dt.timezone(dt.timedelta(hours=5, minutes=30)))
    e["time_of_arrival"] = t.isoformat()
    r = client.post("/api/v1/encounters", json=e, headers=clin)
    assert r.status_code == 201
    stored = dt.datetime.fromisoformat(r.json()["data"]["time_of_arrival"])
    assert stored == t


def test_a_nurse_records_fluid_given_but_not_the_formula(client, auth, encounter):
    eid, nurse = encounter["id"], auth["nurse"]
    url = f"/api/v1/encounters/{eid}/resuscitation"
    given = {"encounter_id": eid, "fluid_given": [{"volume_ml": 250, "given_at": now().isoformat()}]}
    assert client.put(url, json=given, headers={**nurse, "If-None-Match": "*"}).status_code == 201
    abls = {**given, "formula": "abls"}
    r = client.put(url, json=abls, headers={**nurse, "If-Match": '"1"'})
    assert r.status_code == 403 and "formula" in r.json()["detail"]
    assert client.put(url, json=abls, headers={**auth["clinician"], "If-Match": '"1"'}).status_code == 200
    more = {**abls, "fluid_given": [*given["fluid_given"], {"volume_ml": 500, "given_at": now().isoformat()}]}
    assert client.put(url, json=more, headers={**nurse, "If-Match": '"2"'}).status_code == 200
