"""A full clinic record for the center's page tests, made through the clinic's API: intake with an allergy,
medications and tetanus history, ABCDE, secondary survey, mechanism and a burn chart (decision support follows)."""

from __future__ import annotations

from harness.bodies import encounter_body, now, patient_body
from tests.center_pair import Pair

INTAKE = {
    "history_of_present_illness": "Paraffin stove flared while cooking indoors.",
    "past_medical_history": "Mechanical mitral valve, 2015.",
    "significant_comorbidities": ["mechanical heart valve"],
    "medications": [{"name": "Warfarin", "dose": "3 mg at night"}, {"name": "Omeprazole"}],
    "allergies": [{"substance": "Morphine", "reaction": "severe itching and vomiting"}],
    "tetanus_doses": "three_or_more",
    "last_tetanus_dose": "2013-05-20",
    "severe_immunodeficiency": False,
    "social": {"lives_with": "husband and two children"},
}
NEWER_INTAKE_FIELDS = ("tetanus_doses", "last_tetanus_dose", "years_since_last_tetanus_dose", "severe_immunodeficiency")


def put(pair: Pair, eid: str, slug: str, body: dict) -> None:
    r = pair.api.http.put(
        f"/api/v1/encounters/{eid}/{slug}", json={"encounter_id": eid, **body}, headers={"If-None-Match": "*"}
    )
    assert r.status_code == 201, r.text


def encounter(pair: Pair, intake: dict | None) -> str:
    patient = pair.api.post("/api/v1/patients", patient_body(), "patient")
    eid = pair.api.post("/api/v1/encounters", encounter_body(patient["meta"]["id"]), "encounter")["meta"]["id"]
    if intake is not None:
        put(pair, eid, "intake", intake)
    return eid


def full_record(pair: Pair) -> str:
    eid = encounter(pair, INTAKE)
    at = now().isoformat()
    primary = {
        "assessed_at": at,
        "airway": {"patent": True, "hoarse_voice": True, "soot_in_mouth_or_nose": True},
        "breathing": {
            "respiratory_rate_per_min": 26,
            "spo2_percent": 92,
            "oxygen_l_per_min": 15,
            "chest_movement_restricted": False,
        },
        "circulation": {"heart_rate_per_min": 118, "systolic_bp_mmhg": 104, "diastolic_bp_mmhg": 68, "iv_access": True},
        "disability": {"gcs_eye": 4, "gcs_verbal": 5, "gcs_motor": 6, "avpu": "alert"},
        "exposure": {"temperature_c": 36.2, "burn_cooled": True, "cooling_minutes": 20},
    }
    put(pair, eid, "primary-survey", primary)
    secondary = {
        "assessed_at": at,
        "findings": [{"area": "chest", "finding": "soot over the upper chest"}],
        "other_injuries": [{"description": "sprained left wrist"}],
    }
    put(pair, eid, "secondary-survey", secondary)
    put(
        pair,
        eid,
        "mechanism",
        {"type": "flame", "enclosed_space": True, "agent": "paraffin stove", "account_fits_injury": True},
    )
    chart = {
        "assessed_at": at,
        "entries": [
            {"region": "upper_arm_left_anterior", "fraction": 1.0, "depth": "deep_partial"},
            {"region": "trunk_anterior", "fraction": 0.5, "depth": "superficial_partial"},
        ],
    }
    put(pair, eid, "burn-chart", chart)
    return eid


def act(pair: Pair, eid: str, key: str, **body) -> None:
    current = pair.api.http.get(f"/api/v1/encounters/{eid}/decision-support")
    r = pair.api.http.post(
        f"/api/v1/encounters/{eid}/decision-support/acts",
        json={"key": key, **body},
        headers={"If-Match": current.headers["etag"]},
    )
    assert r.status_code == 200, r.text
