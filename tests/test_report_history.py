"""What a clinician must see before treating, in the report over the real app: allergies with their reactions,
current medications with their doses, the tetanus history; "No known allergies" and "not recorded" where that is
what the record says; urgent recommendations before the others."""

from __future__ import annotations

import re

import msgspec
import pytest

from harness.bodies import encounter_body, now, patient_body
from harness.report_pages import page_texts, rasterise
from processing.report.document import render
from schemas.clinical_results import InputRef
from schemas.decision_support import DecisionSupport, Recommendation, RecommendationCategory, Source
from schemas.encounter_snapshot import EncounterSnapshot, Versioned
from schemas.ids import uuid7
from schemas.patient import Encounter, Patient

INTAKE = {
    "history_of_present_illness": "Kettle of boiling water pulled off the counter.",
    "past_medical_history": "Atrial fibrillation since 2019.",
    "significant_comorbidities": ["atrial fibrillation"],
    "medications": [{"name": "Warfarin", "dose": "5 mg once daily"}, {"name": "Bisoprolol"}],
    "allergies": [{"substance": "Penicillin", "reaction": "hives and facial swelling"}, {"substance": "Latex"}],
    "tetanus_doses": "three_or_more",
    "years_since_last_tetanus_dose": 12,
    "severe_immunodeficiency": False,
    "social": {"lives_with": "daughter", "notes": "Uses a walking frame."},
}


@pytest.fixture
def clin(auth):
    return auth["clinician"]


def _encounter(client, clin) -> str:
    patient = patient_body()
    assert client.post("/api/v1/patients", json=patient, headers=clin).status_code == 201
    encounter = encounter_body(patient["id"])
    assert client.post("/api/v1/encounters", json=encounter, headers=clin).status_code == 201
    return encounter["id"]


def _put(client, clin, eid: str, slug: str, body: dict) -> None:
    r = client.put(
        f"/api/v1/encounters/{eid}/{slug}", json={"encounter_id": eid, **body}, headers=clin | {"If-None-Match": "*"}
    )
    assert r.status_code == 201, r.text


def _text(client, clin, eid: str) -> str:
    r = client.get(f"/api/v1/encounters/{eid}/report.pdf", headers=clin)
    assert r.status_code == 200
    return " ".join(" ".join(page_texts(r.content)).split())


def _section(text: str) -> str:
    """The history section: from its heading to the primary survey's."""
    return text.split("History: allergies, medications, tetanus", 1)[1].split("Primary survey (ABCDE)", 1)[0]


def test_the_report_shows_allergies_with_reactions_medications_with_doses_and_the_tetanus_history(
    client, clin, tmp_path
):
    eid = _encounter(client, clin)
    _put(client, clin, eid, "intake", INTAKE)
    r = client.get(f"/api/v1/encounters/{eid}/report.pdf", headers=clin)
    text = " ".join(" ".join(page_texts(r.content)).split())
    history = _section(text)
    assert "Penicillin — reaction: hives and facial swelling" in history
    assert "Latex — reaction: not recorded" in history
    assert "Warfarin — dose: 5 mg once daily" in history and "Bisoprolol — dose: not recorded" in history
    assert "anticoagulant" not in history  # named as recorded, no drug class added
    assert "3 or more prior doses of tetanus-toxoid-containing vaccine" in history
    assert "Last dose about 12 years ago" in history
    assert "Severe immunodeficiency (HIV infection or other): no" in history
    assert (
        "Kettle of boiling water" in history and "atrial fibrillation" in history and "lives with daughter" in history
    )
    assert "No known allergies" not in text and "Allergies not recorded" not in text
    pages = rasterise(r.content, tmp_path / "pages", dpi=80)
    if pages:
        (tmp_path / "pages" / "page-1.png").replace(tmp_path.parent / "history-page-1.png")


def test_no_known_allergies_and_what_is_not_recorded_are_said(client, clin):
    eid = _encounter(client, clin)
    history = _section(_text(client, clin, eid))  # no intake at all
    assert "No intake recorded" in history and "Allergies not recorded" in history
    assert re.search(r"Current medications not recorded", history)
    assert re.search(r"Tetanus history not recorded", history)
    _put(client, clin, eid, "intake", {"no_known_allergies": True, "last_tetanus_dose": "2021-03-04"})
    history = _section(_text(client, clin, eid))
    assert "No known allergies" in history and "Allergies not recorded" not in history
    assert "Prior doses: not recorded" in history and "Last dose on 2021-03-04" in history
    assert "Severe immunodeficiency (HIV infection or other): not recorded" in history
    assert "Current medications not recorded" in history


def test_the_older_tetanus_summary_is_shown_only_when_it_is_all_the_record_holds(client, clin):
    eid = _encounter(client, clin)
    _put(client, clin, eid, "intake", {"tetanus_status": "up_to_date"})
    history = _section(_text(client, clin, eid))
    assert "Tetanus status (older summary form): up to date (last dose within 5 years)" in history
    version = client.get(f"/api/v1/encounters/{eid}/intake", headers=clin).json()["meta"]["version"]
    body = {"encounter_id": eid, "tetanus_status": "up_to_date", "tetanus_doses": "fewer_than_three"}
    r = client.put(f"/api/v1/encounters/{eid}/intake", json=body, headers=clin | {"If-Match": str(version)})
    assert r.status_code == 200, r.text
    history = _section(_text(client, clin, eid))
    assert "fewer than 3 prior doses" in history and "older summary" not in history


def test_urgent_recommendations_come_first_even_when_stored_after_the_others():
    """A decision-support record stored before the rules sorted urgent first still prints urgent first."""
    patient = msgspec.convert(patient_body(), Patient)
    encounter = msgspec.convert(encounter_body(patient.id), Encounter)
    source = Source(guideline="Test guideline", section="1")
    routine = Recommendation(
        key="a.routine",
        category=RecommendationCategory.follow_up,
        text="Review the dressing in 48 hours.",
        source=source,
    )
    urgent = Recommendation(
        key="b.urgent",
        category=RecommendationCategory.tetanus,
        text="Give tetanus immune globulin now.",
        source=source,
        urgent=True,
    )
    support = DecisionSupport(
        encounter_id=encounter.id, computed_at=now(), as_of=now(), inputs=[], recommendations=[routine, urgent]
    )
    inputs = EncounterSnapshot(
        snapshot_id=uuid7(),
        made_at=now(),
        made_by="test",
        software_version="test",
        clinic="Test clinic",
        patient=Versioned(patient, InputRef(kind="patient", id=patient.id, version=1)),
        encounter=Versioned(encounter, InputRef(kind="encounter", id=encounter.id, version=1)),
        decision_support=Versioned(support, InputRef(kind="decision_support", id=encounter.id, version=1)),
    )
    text = " ".join(" ".join(page_texts(render(inputs))).split())
    section = text.split("Judged at", 1)[1]
    assert section.index("Give tetanus immune globulin now.") < section.index("Review the dressing in 48 hours.")
    assert section.index("— URGENT") < section.index("Follow-up")
