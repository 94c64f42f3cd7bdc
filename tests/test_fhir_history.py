"""Allergies, current medications and the tetanus history in the FHIR R4 export over the real app: one
AllergyIntolerance per allergy with its reaction, the "no known allergy" one, one MedicationStatement per medicine
with its dose, the tetanus history as an Observation; nothing invented for what the record lacks. Every Bundle
here is validated by the export itself (fhir.resources R4B) and parsed back below."""

from __future__ import annotations

import pytest

from harness.bodies import encounter_body, patient_body
from processing.fhir import codes
from processing.fhir.bundle import model_of

pytest.importorskip("fhir.resources", reason="the FHIR export needs fhir.resources (pyproject)")


@pytest.fixture
def clin(auth):
    return auth["clinician"]


def _encounter(client, clin, intake: dict | None) -> str:
    patient = patient_body()
    assert client.post("/api/v1/patients", json=patient, headers=clin).status_code == 201
    encounter = encounter_body(patient["id"])
    assert client.post("/api/v1/encounters", json=encounter, headers=clin).status_code == 201
    eid = encounter["id"]
    if intake is not None:
        r = client.put(
            f"/api/v1/encounters/{eid}/intake",
            json={"encounter_id": eid, **intake},
            headers=clin | {"If-None-Match": "*"},
        )
        assert r.status_code == 201, r.text
    return eid


def _bundle(client, clin, eid: str) -> dict:
    r = client.get(f"/api/v1/encounters/{eid}/fhir", headers=clin)
    assert r.status_code == 200, r.text
    bundle = r.json()
    model_of("Bundle").model_validate(bundle)
    return bundle


def _of_type(bundle: dict, resource_type: str) -> list[dict]:
    return [e["resource"] for e in bundle["entry"] if e["resource"]["resourceType"] == resource_type]


def test_allergies_medications_and_tetanus_history_are_exported_as_recorded(client, clin):
    intake = {
        "medications": [{"name": "Apixaban", "dose": "5 mg twice daily"}, {"name": "Metformin"}],
        "allergies": [{"substance": "Penicillin", "reaction": "anaphylaxis"}, {"substance": "Latex"}],
        "tetanus_doses": "three_or_more",
        "last_tetanus_dose": "2014-06-01",
        "severe_immunodeficiency": True,
    }
    eid = _encounter(client, clin, intake)
    bundle = _bundle(client, clin, eid)
    (patient,) = _of_type(bundle, "Patient")
    (encounter,) = _of_type(bundle, "Encounter")
    subject, enc = f"urn:uuid:{patient['id']}", f"urn:uuid:{encounter['id']}"
    allergies = {a["code"]["text"]: a for a in _of_type(bundle, "AllergyIntolerance")}
    assert set(allergies) == {"Penicillin", "Latex"}
    penicillin = allergies["Penicillin"]
    assert penicillin["patient"]["reference"] == subject and penicillin["encounter"]["reference"] == enc
    assert penicillin["reaction"] == [{"manifestation": [{"text": "anaphylaxis"}]}]
    assert penicillin["clinicalStatus"]["coding"][0]["code"] == "active"
    assert "coding" not in penicillin["code"]  # the substance as written: no code looked up
    assert "reaction" not in allergies["Latex"] and "Reaction not recorded" in allergies["Latex"]["note"][0]["text"]
    statements = {m["medicationCodeableConcept"]["text"]: m for m in _of_type(bundle, "MedicationStatement")}
    assert set(statements) == {"Apixaban", "Metformin"}
    apixaban = statements["Apixaban"]
    assert apixaban["status"] == "active" and apixaban["dosage"] == [{"text": "5 mg twice daily"}]
    assert apixaban["subject"]["reference"] == subject and apixaban["context"]["reference"] == enc
    assert "dosage" not in statements["Metformin"] and "Dose not recorded" in statements["Metformin"]["note"][0]["text"]
    (tetanus,) = [
        o for o in _of_type(bundle, "Observation") if o["code"]["coding"][0]["code"] == "tetanus-immunisation-history"
    ]
    assert "3 or more prior doses" in tetanus["valueString"] and "Last dose on 2014-06-01" in tetanus["valueString"]
    assert "Severe immunodeficiency (HIV infection or other): yes" in tetanus["valueString"]
    (provenance,) = _of_type(bundle, "Provenance")
    targets = {t["reference"] for t in provenance["target"]}
    assert {f"urn:uuid:{r['id']}" for r in (penicillin, apixaban, tetanus)} <= targets


def test_no_known_allergies_is_the_conventional_allergy_intolerance(client, clin):
    eid = _encounter(client, clin, {"no_known_allergies": True, "tetanus_status": "not_up_to_date"})
    bundle = _bundle(client, clin, eid)
    (none_known,) = _of_type(bundle, "AllergyIntolerance")
    assert none_known["code"]["coding"] == [
        {"system": codes.SNOMED, "code": "716186003", "display": "No known allergy"}
    ]
    assert none_known["verificationStatus"]["coding"][0]["code"] == "confirmed"
    assert none_known["clinicalStatus"]["coding"][0]["code"] == "active" and "reaction" not in none_known
    assert _of_type(bundle, "MedicationStatement") == []
    (tetanus,) = [
        o for o in _of_type(bundle, "Observation") if o["code"]["coding"][0]["code"] == "tetanus-immunisation-history"
    ]
    assert tetanus["valueString"] == "Tetanus status (older summary form): not up to date"


@pytest.mark.parametrize(
    "intake", [None, {"history_of_present_illness": "Scald from a kettle."}], ids=["no-intake", "empty"]
)
def test_nothing_is_exported_for_what_the_record_does_not_hold(client, clin, intake):
    bundle = _bundle(client, clin, _encounter(client, clin, intake))
    assert _of_type(bundle, "AllergyIntolerance") == [] and _of_type(bundle, "MedicationStatement") == []
    assert not [
        o for o in _of_type(bundle, "Observation") if o["code"]["coding"][0]["code"] == "tetanus-immunisation-history"
    ]
