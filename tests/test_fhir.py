"""The FHIR R4 export over the real app: a record without analyses, the burn chart and %TBSA with their codes,
permissions, and a round trip through fhir.resources' models. The demo's four measured visits are exported in
tests/test_demo.py."""

from __future__ import annotations

import datetime as dt
import json
from pathlib import Path

import msgspec
import pytest

from harness.bodies import encounter_body, now, patient_body
from processing.fhir import codes, record, wound
from processing.fhir.bundle import model_of
from schemas.analysis import AnalysisResult, AnalysisStatus, BurnMetrics
from schemas.clinical_results import InputRef
from schemas.encounter_snapshot import AnalysisVisit, Versioned
from schemas.ids import uuid7
from schemas.jobs import BurnAnalysis
from schemas.patient import Encounter
from schemas.transfer import Consultation, ConsultationNote, Recommendation

fhir_resources = pytest.importorskip("fhir.resources", reason="the FHIR export needs fhir.resources (pyproject)")


@pytest.fixture
def clin(auth):
    return auth["clinician"]


@pytest.fixture
def charted(client, clin) -> dict:
    patient = patient_body(given_name="Amara", family_name="Okafor", medical_record_number="MRN-4471")
    assert client.post("/api/v1/patients", json=patient, headers=clin).status_code == 201
    encounter = encounter_body(patient["id"])
    assert client.post("/api/v1/encounters", json=encounter, headers=clin).status_code == 201
    eid = encounter["id"]
    chart = {
        "encounter_id": eid,
        "assessed_at": now().isoformat(),
        "entries": [
            {"region": "trunk_anterior", "fraction": 0.5, "depth": "deep_partial"},
            {"region": "trunk_anterior", "fraction": 0.5, "depth": "superficial_partial"},
            {"region": "thigh_right_anterior", "fraction": 0.5, "depth": "full_thickness"},
            {"region": "lower_arm_left_posterior", "fraction": 1.0, "depth": "superficial"},
        ],
    }
    r = client.put(f"/api/v1/encounters/{eid}/burn-chart", json=chart, headers={**clin, "If-None-Match": "*"})
    assert r.status_code == 201
    return {"patient": patient, "encounter": encounter, "chart": chart}


def _export(client, headers, eid):
    return client.get(f"/api/v1/encounters/{eid}/fhir", headers=headers)


def _of_type(bundle: dict, resource_type: str) -> list[dict]:
    return [e["resource"] for e in bundle["entry"] if e["resource"]["resourceType"] == resource_type]


def _code(concept: dict, system: str) -> str:
    return next((c["code"] for c in concept["coding"] if c["system"] == system), None)


def test_a_record_without_analyses_exports_the_burns_and_tbsa_and_no_wound_size(client, clin, charted):
    eid = charted["encounter"]["id"]
    r = _export(client, clin, eid)
    assert r.status_code == 200 and r.headers["content-type"].startswith("application/fhir+json")
    bundle = r.json()
    assert bundle["resourceType"] == "Bundle" and bundle["type"] == "collection"
    (patient,) = _of_type(bundle, "Patient")
    assert patient["name"][0] == {"use": "official", "family": "Okafor", "given": ["Amara"]}
    assert {"system": f"{codes.LOCAL_ID}/mrn", "value": "MRN-4471"}.items() <= patient["identifier"][1].items()
    (encounter,) = _of_type(bundle, "Encounter")
    assert encounter["class"]["code"] == "EMER" and "start" in encounter["period"]
    assert len({e["fullUrl"] for e in bundle["entry"]}) == len(bundle["entry"])  # every resource once
    found = _of_type(bundle, "Condition")
    assert len(found) == 4  # one region charted at two depths is two burns
    conditions = {_code(c["bodySite"][0], codes.LOCAL_REGION): c for c in found}
    assert set(conditions) == {"trunk_anterior", "thigh_right_anterior", "lower_arm_left_posterior"}
    thigh = conditions["thigh_right_anterior"]
    assert _code(thigh["code"], codes.SNOMED) == "403192003"  # full thickness burn
    assert _code(thigh["bodySite"][0], codes.SNOMED) == "68367000" and "right thigh" in thigh["bodySite"][0]["text"]
    trunk = {_code(c["code"], codes.LOCAL_DEPTH) for c in found if c["bodySite"][0]["text"].startswith("trunk")}
    assert trunk == {"deep_partial", "superficial_partial"}
    assert _code(conditions["lower_arm_left_posterior"]["bodySite"][0], codes.SNOMED) == "14975008"  # forearm
    assert thigh["verificationStatus"]["coding"][0]["code"] == "provisional"  # charted 3 h after the injury
    injured = dt.datetime.fromisoformat(charted["encounter"]["time_of_injury"])
    assert dt.datetime.fromisoformat(thigh["onsetDateTime"]) == injured
    stored = client.get(f"/api/v1/encounters/{eid}/assessment", headers=clin).json()["data"]["tbsa"]
    (tbsa,) = [o for o in _of_type(bundle, "Observation") if _code(o["code"], codes.LOCAL_OBSERVATION) == "tbsa-burned"]
    assert tbsa["valueQuantity"]["value"] == round(stored["tbsa_percent"], 1) and tbsa["valueQuantity"]["unit"] == "%"
    wound_sizes = [o for o in _of_type(bundle, "Observation") if o["code"]["coding"][0]["code"] == "72287-6"]
    assert wound_sizes == [] and _of_type(bundle, "Media") == []  # no analysis: no figures, none invented
    (report,) = _of_type(bundle, "DocumentReference")
    attachment = report["content"][0]["attachment"]
    pdf = client.get(attachment["url"], headers=clin)
    assert pdf.status_code == 200 and len(pdf.content) == attachment["size"]
    (provenance,) = _of_type(bundle, "Provenance")
    assert len(provenance["target"]) == len(bundle["entry"]) - 1
    assert any(a["type"]["coding"][0]["code"] == "assembler" for a in provenance["agent"])


def test_the_exported_json_parses_back_with_the_fhir_models(client, clin, charted):
    text = _export(client, clin, charted["encounter"]["id"]).text
    parsed = model_of("Bundle").model_validate_json(text)
    again = json.loads(parsed.model_dump_json(exclude_none=True))
    assert again["entry"] and len(again["entry"]) == len(json.loads(text)["entry"])
    for entry in json.loads(text)["entry"]:
        resource = entry["resource"]
        model = model_of(resource["resourceType"]).model_validate(resource)
        assert json.loads(model.model_dump_json(exclude_none=True))["id"] == resource["id"]


def test_who_may_export(client, auth, charted):
    eid = charted["encounter"]["id"]
    for role in ("clinician", "nurse", "consultant"):
        assert _export(client, auth[role], eid).status_code == 200
    assert _export(client, auth["admin"], eid).status_code == 403
    unknown = _export(client, auth["clinician"], "0192f3b4-6a8e-7c3d-9b1a-000000000000")
    assert unknown.status_code == 404 and unknown.headers["content-type"].startswith("application/problem+json")
    assert client.get(f"/api/v1/encounters/{eid}/fhir").status_code == 401
    gone = client.delete(
        f"/api/v1/encounters/{eid}", params={"reason": "opened twice"}, headers={**auth["clinician"], "If-Match": '"1"'}
    )
    assert gone.status_code == 200
    assert _export(client, auth["clinician"], eid).status_code == 409  # withdrawn: nothing exported


def _page(result) -> AnalysisVisit:
    value = BurnAnalysis(
        encounter_id=uuid7(),
        job_id=uuid7(),
        assets=[],
        requested_by="nurse",
        requested_at="2026-11-13T05:00:00+00:00",
        completed_at="2026-11-13T05:09:00+00:00",
        result=result,
    )
    return AnalysisVisit(
        Versioned(value, InputRef(kind="burn_analysis", id=value.job_id, version=1)), Path("."), "visit"
    )


def test_without_a_metric_scale_no_figure_is_exported_and_a_note_says_why():
    subject, enc = {"reference": "urn:uuid:p"}, {"reference": "urn:uuid:e"}
    unscaled = AnalysisResult(
        status=AnalysisStatus.unscaled,
        metrics=BurnMetrics(area_model_units2=3.2, burn_loops=1),
        hours_since_injury=100.0,
        provisional=False,
    )
    panel = wound.wound_size(_page(unscaled), subject, enc, [], None)
    assert "component" not in panel and panel["status"] == "final"
    assert "No metric scale" in panel["note"][0]["text"]
    model_of("Observation").model_validate(panel)
    scaled = AnalysisResult(
        status=AnalysisStatus.ok,
        metrics=BurnMetrics(area_cm2=12.345, perimeter_cm=13.1, relief_max_mm=2.4, volume_cm3=0.61),
        hours_since_injury=None,
    )
    panel = wound.wound_size(_page(scaled), subject, enc, [], None)
    assert "derivedFrom" not in panel  # no photo file found: no empty list
    values = {c["code"]["coding"][0]["code"]: c["valueQuantity"] for c in panel["component"]}
    assert values["89260-4"]["value"] == 12.35 and values["89260-4"]["code"] == "cm2"
    assert values["39127-6"] == {"value": 0.24, "unit": "cm", "system": codes.UCUM, "code": "cm"}
    assert values["woundvolume"]["code"] == "mL" and values["wound-perimeter"]["value"] == 13.1
    # no time since injury: possibly under 72 h, so provisional
    assert panel["status"] == "preliminary" and "unknown time" in panel["note"][0]["text"]
    model_of("Observation").model_validate(panel)


def test_a_consultants_advice_becomes_a_communication_with_its_notice():
    note = ConsultationNote(
        note_id=uuid7(),
        encounter_id=uuid7(),
        patient_id=uuid7(),
        bundle_id=uuid7(),
        bundle_version=2,
        center_id="center-north",
        consultant="Dr. Achieng Otieno",
        consultant_user_id=uuid7(),
        written_at="2026-11-13T09:30:00+00:00",
        recommendation=Recommendation.transfer,
        advice="Full-thickness thigh burn: transfer for excision and grafting; keep warm, cling film.",
    )
    stored = Consultation(
        encounter_id=note.encounter_id, note=note, received_at="2026-11-13T09:31:05+00:00", signed_by="center-north"
    )
    subject, enc = {"reference": "urn:uuid:p"}, {"reference": "urn:uuid:e"}
    (sent,) = record.communications(
        [Versioned(stored, InputRef(kind="consultation", id=note.note_id, version=1))], subject, enc
    )
    model_of("Communication").model_validate(sent)
    assert sent["sender"]["display"] == "Dr. Achieng Otieno (center-north)"
    assert sent["sent"] == note.written_at and sent["received"] == stored.received_at
    texts = [p["contentString"] for p in sent["payload"]]
    assert texts[0].startswith("Recommendation: transfer.") and note.advice in texts[0]
    assert "has not examined the patient" in texts[1]


def test_a_raised_burn_gets_no_relief_component_and_a_note_why():
    raised = AnalysisResult(
        status=AnalysisStatus.ok,
        metrics=BurnMetrics(area_cm2=6.0, perimeter_cm=9.0, relief_max_mm=-0.4, raised_max_mm=1.2, volume_cm3=0.0),
        hours_since_injury=80.0,
        provisional=False,
        notes=["surface relief and volume are uncertain: the healthy skin around the burn is uneven"],
    )
    panel = wound.wound_size(_page(raised), {"reference": "urn:uuid:p"}, {"reference": "urn:uuid:e"}, [], None)
    codes_given = {c["code"]["coding"][0]["code"] for c in panel["component"]}
    assert "39127-6" not in codes_given and "89260-4" in codes_given
    texts = " ".join(n["text"] for n in panel["note"])
    assert "not below the healthy skin" in texts and "relief and volume are uncertain" in texts
    model_of("Observation").model_validate(panel)


def test_a_patient_and_an_encounter_sharing_a_record_id_are_two_resources(client, clin):
    shared = uuid7()  # record ids are unique per kind, not across kinds (the API fuzzing found this)
    patient = patient_body(patient_id=shared)
    assert client.post("/api/v1/patients", json=patient, headers=clin).status_code == 201
    encounter = encounter_body(shared, encounter_id=shared)
    assert client.post("/api/v1/encounters", json=encounter, headers=clin).status_code == 201
    r = _export(client, clin, shared)
    assert r.status_code == 200, r.text
    bundle = r.json()
    assert len({e["fullUrl"] for e in bundle["entry"]}) == len(bundle["entry"])
    (p,), (e,) = _of_type(bundle, "Patient"), _of_type(bundle, "Encounter")
    assert p["identifier"][0]["value"] == e["identifier"][0]["value"] == shared and p["id"] != e["id"]
    assert e["subject"] == {"reference": f"urn:uuid:{p['id']}"}


def test_the_patients_sharing_choice_becomes_a_privacy_consent_and_could_not_ask_makes_none(client, clin, charted):
    from processing.fhir.consent import consent

    eid = charted["encounter"]["id"]
    (given,) = _of_type(_export(client, clin, eid).json(), "Consent")  # the patient agreed (harness default)
    assert given["provision"]["type"] == "permit" and given["performer"][0]["display"] == "the patient"
    current = client.get(f"/api/v1/encounters/{eid}", headers=clin).json()
    for version, choice in enumerate(("not_possible", "given_by_guardian"), start=1):
        body = {**current["data"], "sharing_consent": choice}
        r = client.put(f"/api/v1/encounters/{eid}", json=body, headers={**clin, "If-Match": f'"{version}"'})
        assert r.status_code == 200, r.text
        if choice == "not_possible":  # not a consent: no Consent resource
            assert _of_type(_export(client, clin, eid).json(), "Consent") == []
    (guardian,) = _of_type(_export(client, clin, eid).json(), "Consent")
    model_of("Consent").model_validate(guardian)
    assert guardian["status"] == "active" and guardian["provision"]["type"] == "permit"
    assert _code(guardian["scope"], "http://terminology.hl7.org/CodeSystem/consentscope") == "patient-privacy"
    assert _code(guardian["category"][0], "http://loinc.org") == "59284-0"
    assert "guardian" in guardian["performer"][0]["display"] and guardian["patient"]["reference"].startswith("urn:")
    refused = Versioned(
        msgspec.convert({**body, "sharing_consent": "refused"}, Encounter),
        InputRef(kind="encounter", id=eid, version=4),
    )
    denied = consent(refused, {"reference": "urn:uuid:p"})
    model_of("Consent").model_validate(denied)
    assert denied["provision"]["type"] == "deny"
    unrecorded = msgspec.structs.replace(refused, value=msgspec.structs.replace(refused.value, sharing_consent=None))
    assert consent(unrecorded, {"reference": "urn:uuid:p"}) is None
