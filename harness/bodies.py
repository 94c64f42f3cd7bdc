"""Request bodies for a patient and an encounter, as a phone would send them."""

from __future__ import annotations

import datetime as dt

from schemas.ids import uuid7


def now() -> dt.datetime:
    return dt.datetime.now(dt.UTC).replace(microsecond=0)


def patient_body(patient_id: str | None = None, **extra) -> dict:
    body = {
        "id": patient_id or uuid7(),
        "given_name": "Test",
        "family_name": "Patient",
        "date_of_birth": "1990-01-01",
        "sex": "male",
        "weight_kg": 70.0,
        "height_cm": 175.0,
    }
    body.update(extra)
    return body


def encounter_body(patient_id: str, encounter_id: str | None = None, injury_hours_ago: float = 3, **extra) -> dict:
    t = now()
    body = {
        "id": encounter_id or uuid7(),
        "patient_id": patient_id,
        "mode": "emergency",
        "time_of_injury": (t - dt.timedelta(hours=injury_hours_ago)).isoformat(),
        "time_of_arrival": (t - dt.timedelta(hours=min(injury_hours_ago, 0.5))).isoformat(),
        "clinician": "Dr. Test",
        "sharing_consent": "given",
    }
    body.update(extra)
    return body


def wound_body(patient_id: str, wound_id: str | None = None, **extra) -> dict:
    """A wound of the patient: a scald of the left forearm unless `extra` says otherwise."""
    body = {
        "id": wound_id or uuid7(),
        "patient_id": patient_id,
        "regions": ["lower_arm_left_anterior", "hand_left_dorsal"],
        "label": "left forearm",
        "side": "left",
        "site_detail": "ulnar border to the back of the hand",
        "cause": "scald",
    }
    body.update(extra)
    return body
