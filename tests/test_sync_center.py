"""A clinic gateway and a burn center, each a real process, talking Zenoh over TCP on loopback."""

from __future__ import annotations

import sqlite3
from pathlib import Path

import pytest

from tests.conftest import encounter_body, patient_body
from tests.sync_sites import Sites, noise_photo, wait_for

pytestmark = pytest.mark.server


@pytest.fixture
def sites(tmp_path: Path):
    sites = Sites(tmp_path)
    sites.set_up()
    yield sites
    sites.stop()


def record_case(client, tmp_path: Path, photos: int, seed: int = 0) -> tuple[str, list[Path]]:
    patient = client.post("/api/v1/patients", patient_body(), "patient")
    encounter = client.post("/api/v1/encounters", encounter_body(patient["meta"]["id"]), "encounter")
    encounter_id = encounter["meta"]["id"]
    paths = [noise_photo(tmp_path / f"photo-{seed}-{i}.jpg", seed * 100 + i) for i in range(photos)]
    for path in paths:
        client.upload(path, encounter_id)
    return encounter_id, paths


def delivered(client, encounter_id: str, version: int):
    entries = client.get(f"/api/v1/encounters/{encounter_id}/transfers", "transfers")
    return next((e for e in entries if e["version"] == version and e["state"] == "delivered"), None)


def test_case_arrives_intact_and_advice_comes_back(sites: Sites, tmp_path: Path):
    sites.center.start()
    sites.gateway.start()
    clinic = sites.clinic_client()
    encounter_id, photos = record_case(clinic, tmp_path, photos=2)

    sent = clinic.http.post(f"/api/v1/encounters/{encounter_id}/transfers")
    assert sent.status_code == 202, sent.text
    entry = wait_for(lambda: delivered(clinic, encounter_id, 1), 30, "delivery of version 1")
    assert entry["bundle_id"] == sent.json()["bundle_id"]

    center = sites.center_client()
    cases = center.get("/api/v1/cases", "cases")
    assert [c["encounter_id"] for c in cases] == [encounter_id]
    assert cases[0]["awaiting_advice"] and cases[0]["site_name"] == "Test field clinic"
    detail = center.get(f"/api/v1/cases/{cases[0]['site_id']}/{entry['bundle_id']}", "case")
    names = [p["name"] for p in detail["manifest"]["parts"]]
    received = sorted(center.http.get(f"/api/v1/cases/{cases[0]['site_id']}/{entry['bundle_id']}/parts/{n}").content
                      for n in names if n.startswith("photos/"))  # fmt: skip
    assert received == sorted(p.read_bytes() for p in photos)  # byte-identical after decryption
    record = center.http.get(f"/api/v1/cases/{cases[0]['site_id']}/{entry['bundle_id']}/parts/record.json").json()
    assert record["encounter"]["meta"]["id"] == encounter_id

    note = center.post(f"/api/v1/cases/{cases[0]['site_id']}/{entry['bundle_id']}/notes",
                       {"recommendation": "manage_locally", "advice": "Dress with silver sulfadiazine; review in "
                        "48 h with new photos."}, "note")  # fmt: skip
    notes = wait_for(lambda: clinic.get(f"/api/v1/encounters/{encounter_id}/consultations", "notes"), 30,
                     "the consultant's note at the clinic")  # fmt: skip
    assert len(notes) == 1
    got = notes[0]["data"]["note"]
    assert got["note_id"] == note["note"]["note_id"] and got["consultant"] == "Dr Consultant"
    assert got["advice"].startswith("Dress with silver") and notes[0]["data"]["signed_by"] == "center-test"
    wait_for(lambda: center.get(f"/api/v1/cases/{cases[0]['site_id']}/{entry['bundle_id']}", "case")["notes"][0]
             ["delivered_at"], 30, "the clinic's acknowledgement of the note")  # fmt: skip

    # Nothing changed: no second version. Another photo: version 2 supersedes version 1, which stays readable.
    again = clinic.http.post(f"/api/v1/encounters/{encounter_id}/transfers")
    assert again.status_code == 200 and again.json()["unchanged"] and again.json()["version"] == 1
    clinic.upload(noise_photo(tmp_path / "later.jpg", 99), encounter_id)
    assert clinic.http.post(f"/api/v1/encounters/{encounter_id}/transfers").json()["version"] == 2
    second = wait_for(lambda: delivered(clinic, encounter_id, 2), 30, "delivery of version 2")
    latest = center.get("/api/v1/cases", "cases")
    assert [(c["bundle_id"], c["version"]) for c in latest] == [(second["bundle_id"], 2)]
    everything = center.get("/api/v1/cases?include_superseded=true", "all versions")
    assert {c["version"]: c["superseded_by"] for c in everything} == {1: second["bundle_id"], 2: None}
    with sqlite3.connect(sites.center.env["BURNEDGE_CENTRAL_DATABASE"]) as db:
        assert db.execute("SELECT COUNT(*) FROM bundles").fetchone()[0] == 2
        assert db.execute("SELECT COUNT(*) FROM incoming").fetchone()[0] == 0
