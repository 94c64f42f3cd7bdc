"""The issue's house-fire case through the real gateway process over HTTP: the record as a phone sends it, the
recommendations with their urgency and order, and the PDF report's text."""

from __future__ import annotations

import datetime as dt
import re

import httpx
import msgspec
import pytest

from harness.bodies import encounter_body, patient_body
from harness.processes import PASSWORD, add_user_cli
from harness.report_pages import page_texts
from schemas.burn_chart import BurnChart
from tests import major_burn_case as case

pytestmark = pytest.mark.server


def _put(http: httpx.Client, headers: dict, eid: str, slug: str, part: msgspec.Struct) -> None:
    r = http.put(
        f"/api/v1/encounters/{eid}/{slug}",
        json=msgspec.to_builtins(part),
        headers={**headers, "If-None-Match": "*"},
    )
    assert r.status_code == 201, r.text


def test_a_major_burn_gets_urgent_airway_oxygen_escharotomy_and_opioid_advice_in_the_api_and_the_report(
    gateway_process,
):
    add_user_cli(gateway_process.db, "clinician", "clinician")
    gw = gateway_process.start()
    with httpx.Client(base_url=gw.url, timeout=60) as http:
        token = http.post("/api/v1/auth/login", json={"username": "clinician", "password": PASSWORD}).json()
        h = {"Authorization": f"Bearer {token['access_token']}"}
        patient = patient_body(date_of_birth="1981-05-02", weight_kg=80.0, height_cm=178.0)
        assert http.post("/api/v1/patients", json=patient, headers=h).status_code == 201
        encounter = encounter_body(patient["id"], injury_hours_ago=2)
        eid = encounter["id"]
        assert http.post("/api/v1/encounters", json=encounter, headers=h).status_code == 201
        seen = dt.datetime.now(dt.UTC).replace(microsecond=0) - dt.timedelta(minutes=30)
        _put(http, h, eid, "intake", case.intake(eid))
        _put(http, h, eid, "primary-survey", case.primary(eid, seen))
        _put(http, h, eid, "mechanism", case.mechanism(eid))
        _put(http, h, eid, "burn-chart", BurnChart(encounter_id=eid, assessed_at=seen, entries=case.chart_entries()))

        r = http.get(f"/api/v1/encounters/{eid}/decision-support", headers=h)
        assert r.status_code == 200, r.text
        recs = r.json()["data"]["recommendations"]
        keys = [x["key"] for x in recs]
        urgent = [x["key"] for x in recs if x["urgent"]]
        assert urgent == keys[: len(urgent)], "urgent recommendations lead"
        assert urgent[:3] == ["airway.inhalation", "breathing.oxygen", "circulation.limb"]
        assert {"pain.opioid", "tetanus", "fluids.plan", "follow_up.referral"} <= set(urgent)
        by_key = {x["key"]: x for x in recs}
        assert all(x["state"] == "pending" for x in recs)
        assert "carboxyhaemoglobin 18 %" in by_key["breathing.oxygen"]["text"]
        assert "absent distal pulses" in by_key["circulation.limb"]["text"]
        assert any("Apixaban 5 mg twice daily" in d for d in by_key["circulation.limb"]["details"])
        opioid = by_key["pain.opioid"]["text"]
        assert "morphine is not advised: allergy recorded to Morphine (rash and wheeze)" in opioid
        assert "Give tetanus immune globulin" in by_key["tetanus"]["text"]
        assert {i["kind"] for i in by_key["airway.inhalation"]["inputs"]} >= {"primary_survey", "mechanism"}

        pdf = http.get(f"/api/v1/encounters/{eid}/report.pdf", headers=h)
        assert pdf.status_code == 200
        text = " ".join(" ".join(page_texts(pdf.content)).split())
        for words in ("Airway at risk", "100 % high-flow oxygen", "escharotomy", "Morphine", "rash and wheeze"):
            assert words in text, words
        assert "Apixaban" in text
        positions = [text.find(w) for w in ("Airway at risk", "Oxygen: carboxyhaemoglobin", "Elevate the burned limb")]
        assert positions == sorted(positions) and -1 not in positions, "urgent advice is printed first"
        assert re.search(r"URGENT", text)
    gw.stop()
