"""The PACS send's API (gateway/documents/pacs_controller.py, docs/api.md) against a real Orthanc: POST sends the
encounter's study and answers with the send as recorded, GET lists the sends with their state; a second send adds
nothing; an unreachable PACS is a 502 problem with its reason, recorded as failed; no configured PACS is a 409; an
unknown encounter a 404; no session a 401."""

from __future__ import annotations

from litestar.testing import TestClient

from burnedge.demo_client import GatewayClient
from harness.processes import PASSWORD, free_port
from tests.dicom_clinic import Clinic

PROBLEM = "application/problem+json"


def _signed_in(http: TestClient) -> None:
    GatewayClient(http=http).login("clin", PASSWORD)


def test_post_sends_the_study_and_get_lists_the_sends_with_their_state(orthanc, tmp_path):
    clinic = Clinic(tmp_path, orthanc.dicomweb_url)
    with TestClient(clinic.app) as http:
        encounter_id = clinic.analysed_encounter(http)
        url = f"/api/v1/encounters/{encounter_id}/pacs-sends"
        assert http.post(url).status_code == 401  # no session
        _signed_in(http)
        assert http.get(url).json() == []
        first = http.post(url)
        assert first.status_code == 201 and first.headers["location"] == url
        sent = first.json()
        assert (sent["state"], sent["instances"], sent["already_there"]) == ("sent", 5, 0)
        assert sent["endpoint"] == orthanc.dicomweb_url and "pacs-test-password" not in first.text
        with orthanc.client() as pacs:
            stats = pacs.get("/statistics").json()
            assert (stats["CountStudies"], stats["CountInstances"]) == (1, 5)
            (study,) = pacs.get("/studies", params={"expand": "1"}).json()
            assert study["MainDicomTags"]["StudyInstanceUID"] == sent["study_uid"]
        again = http.post(url).json()
        assert (again["state"], again["already_there"]) == ("sent", 5)  # replaced, nothing added
        with orthanc.client() as pacs:
            assert pacs.get("/statistics").json()["CountInstances"] == 5
        listed = http.get(url).json()
        assert [s["id"] for s in listed] == [again["id"], sent["id"]] and {s["state"] for s in listed} == {"sent"}
        missing = "/api/v1/encounters/0190a6a0-0000-7000-8000-000000000000/pacs-sends"
        assert http.get(missing).status_code == 404 and http.post(missing).status_code == 404


def test_an_unreachable_pacs_is_a_502_with_its_reason_and_the_failed_send_is_listed(tmp_path):
    clinic = Clinic(tmp_path, f"http://127.0.0.1:{free_port()}/dicom-web")  # nothing listens there
    with TestClient(clinic.app) as http:
        encounter_id = clinic.analysed_encounter(http)
        _signed_in(http)
        url = f"/api/v1/encounters/{encounter_id}/pacs-sends"
        r = http.post(url)
        assert r.status_code == 502 and r.headers["content-type"].startswith(PROBLEM)
        problem = r.json()
        assert problem["title"] == "The hospital's PACS did not store the study"
        assert "cannot be reached" in problem["detail"] and "nothing was marked as sent" in problem["detail"]
        (failed,) = http.get(url).json()
        assert failed["state"] == "failed" and failed["error"] == problem["detail"]


def test_without_a_configured_pacs_a_send_is_a_409_and_nothing_is_recorded(tmp_path):
    clinic = Clinic(tmp_path, "")
    with TestClient(clinic.app) as http:
        encounter_id = clinic.analysed_encounter(http)
        _signed_in(http)
        url = f"/api/v1/encounters/{encounter_id}/pacs-sends"
        r = http.post(url)
        assert r.status_code == 409 and r.headers["content-type"].startswith(PROBLEM)
        assert "no PACS is configured" in r.json()["detail"]
        assert http.get(url).json() == []
