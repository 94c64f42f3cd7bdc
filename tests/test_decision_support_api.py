"""Decision support over the real app: stored per encounter, pending until a clinician acts, versioned, audited."""

from __future__ import annotations

import pytest

from harness.bodies import encounter_body, patient_body


@pytest.fixture
def clin(auth):
    return auth["clinician"]


@pytest.fixture
def eid(client, clin) -> str:
    patient = patient_body()
    assert client.post("/api/v1/patients", json=patient, headers=clin).status_code == 201
    encounter = encounter_body(patient["id"])
    assert client.post("/api/v1/encounters", json=encounter, headers=clin).status_code == 201
    return encounter["id"]


def _intake(client, clin, eid, **fields):
    url = f"/api/v1/encounters/{eid}/intake"
    current = client.get(url, headers=clin)
    body = {"encounter_id": eid, **fields}
    if current.status_code == 404:
        return client.put(url, json=body, headers={**clin, "If-None-Match": "*"})
    return client.put(url, json=body, headers={**clin, "If-Match": current.headers["etag"]})


def _support(client, headers, eid):
    r = client.get(f"/api/v1/encounters/{eid}/decision-support", headers=headers)
    assert r.status_code == 200, r.text
    return r.headers["etag"], {x["key"]: x for x in r.json()["data"]["recommendations"]}


def _act(client, headers, eid, etag, **body):
    return client.post(
        f"/api/v1/encounters/{eid}/decision-support/acts", json=body, headers={**headers, "If-Match": etag}
    )


def _audit_actions(services) -> list[str]:
    entries = services.db.connection().execute("SELECT action FROM audit_log ORDER BY seq").fetchall()
    return [e[0] for e in entries]


def test_recommendations_start_pending_and_a_clinician_accepts_one(client, clin, eid, services):
    assert _intake(client, clin, eid, tetanus_doses="three_or_more", years_since_last_tetanus_dose=6).status_code == 201
    etag, recs = _support(client, clin, eid)
    assert recs["tetanus"]["state"] == "pending" and "give Tdap (or Td" in recs["tetanus"]["text"]
    assert recs["tetanus"]["source"]["year"] >= 2018
    accepted = _act(client, clin, eid, etag, key="tetanus", state="accepted")
    assert accepted.status_code == 200, accepted.text
    tetanus = {x["key"]: x for x in accepted.json()["data"]["recommendations"]}["tetanus"]
    assert (tetanus["state"], tetanus["decided_by"]) == ("accepted", "clinician")
    assert int(accepted.headers["etag"].strip('"')) == int(etag.strip('"')) + 1
    assert "recommendation.accepted" in _audit_actions(services)
    assert services.verify_audit(None).ok


def test_declining_needs_a_reason_and_a_stale_version_is_refused(client, clin, eid):
    _intake(client, clin, eid, tetanus_doses="fewer_than_three")
    etag, _ = _support(client, clin, eid)
    no_reason = _act(client, clin, eid, etag, key="tetanus", state="declined")
    assert no_reason.status_code == 422 and "reason" in no_reason.json()["detail"]
    declined = _act(client, clin, eid, etag, key="tetanus", state="declined", reason="TIG given by the ambulance crew")
    assert declined.status_code == 200
    stale = _act(client, clin, eid, etag, key="tetanus", state="accepted")
    assert stale.status_code == 412
    unknown = _act(client, clin, eid, declined.headers["etag"], key="nonsense", state="accepted")
    assert unknown.status_code == 422 and "tetanus" in unknown.json()["detail"]
    assert (
        client.post(
            f"/api/v1/encounters/{eid}/decision-support/acts",
            json={"key": "tetanus", "state": "accepted"},
            headers=clin,
        ).status_code
        == 428
    )


def test_only_a_clinician_acts_and_an_unknown_encounter_is_404(client, auth, clin, eid):
    _intake(client, clin, eid, tetanus_doses="fewer_than_three")
    etag, _ = _support(client, auth["nurse"], eid)
    for role in ("nurse", "consultant"):
        assert _act(client, auth[role], eid, etag, key="tetanus", state="accepted").status_code == 403
    assert client.get(f"/api/v1/encounters/{eid}/decision-support", headers=auth["admin"]).status_code == 403
    missing = "0192f3b4-6a8e-7c3d-9b1a-000000000000"
    assert client.get(f"/api/v1/encounters/{missing}/decision-support", headers=clin).status_code == 404


def test_an_act_survives_a_resave_but_not_changed_advice(client, clin, eid):
    _intake(client, clin, eid, tetanus_doses="three_or_more", years_since_last_tetanus_dose=6)
    etag, _ = _support(client, clin, eid)
    _act(client, clin, eid, etag, key="tetanus", state="accepted")
    # Another field of the intake changes: the tetanus advice and its inputs do not.
    _intake(
        client, clin, eid, tetanus_doses="three_or_more", years_since_last_tetanus_dose=6, past_medical_history="asthma"
    )
    _, recs = _support(client, clin, eid)
    assert recs["tetanus"]["state"] == "accepted"
    _intake(client, clin, eid, tetanus_doses="fewer_than_three")
    _, recs = _support(client, clin, eid)
    assert recs["tetanus"]["state"] == "pending" and "immune globulin" in recs["tetanus"]["text"]
    history = client.get(f"/api/v1/encounters/{eid}/decision-support/history", headers=clin).json()["versions"]
    states = [{x["key"]: x["state"] for x in v["data"]["recommendations"]}["tetanus"] for v in history]
    assert states[0] == "pending" and "accepted" in states and states[-1] == "pending"


def test_tetanus_history_that_cannot_be_right_is_refused(client, clin, eid):
    future = _intake(client, clin, eid, last_tetanus_dose="2999-01-01")
    assert future.status_code == 422 and future.json()["errors"][0]["field"] == "$.last_tetanus_dose"
    both = _intake(client, clin, eid, last_tetanus_dose="2020-01-01", years_since_last_tetanus_dose=3)
    assert both.status_code == 422 and "not both" in both.json()["detail"]
    negative = _intake(client, clin, eid, years_since_last_tetanus_dose=-1)
    assert negative.status_code == 400
