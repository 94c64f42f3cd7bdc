"""A case the patient refused to have sent stays at the clinic, whatever asks for it (the API here; the pages'
confirmation is driven in tests/test_browser_clinic.py), and the refusal is the encounter's recorded consent."""

from __future__ import annotations

from harness.bodies import encounter_body, patient_body


def test_a_refused_consent_stops_the_sending(client, auth):
    clin = auth["clinician"]
    patient = patient_body()
    client.post("/api/v1/patients", json=patient, headers=clin)
    encounter = encounter_body(patient["id"], sharing_consent="refused")
    assert client.post("/api/v1/encounters", json=encounter, headers=clin).status_code == 201
    r = client.post(f"/api/v1/encounters/{encounter['id']}/transfers", headers=clin)
    assert r.status_code == 409 and "refused" in r.json()["detail"]


def test_an_unknown_consent_value_is_refused_at_its_field(client, auth):
    clin = auth["clinician"]
    patient = patient_body()
    client.post("/api/v1/patients", json=patient, headers=clin)
    r = client.post("/api/v1/encounters", json=encounter_body(patient["id"], sharing_consent="maybe"), headers=clin)
    assert r.status_code in (400, 422) and "sharing_consent" in r.text


def test_a_case_is_not_sent_before_the_patients_choice_is_recorded(client, auth):
    clin = auth["clinician"]
    patient = patient_body()
    client.post("/api/v1/patients", json=patient, headers=clin)
    encounter = encounter_body(patient["id"])
    del encounter["sharing_consent"]
    assert client.post("/api/v1/encounters", json=encounter, headers=clin).status_code == 201
    r = client.post(f"/api/v1/encounters/{encounter['id']}/transfers", headers=clin)
    assert r.status_code == 409 and "consent to sending the case is not recorded" in r.json()["detail"]
