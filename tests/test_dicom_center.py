"""The burn center forwards a received case to its hospital's PACS from the case page (a real Orthanc,
harness/orthanc.py): the case as the clinic sent it (tests/center_pair.py: a clinic gateway in this process sends it
over Zenoh on loopback) becomes one study with the photo, the SR, the surface and the report; a second send adds
nothing; a stopped PACS is shown as failed with its reason."""

from __future__ import annotations

import io

import msgspec
import pytest
from pydicom import dcmread

from center.pacs import CenterPacsService
from harness.bodies import encounter_body, patient_body, wound_body
from harness.orthanc import PASSWORD as PACS_PASSWORD
from harness.orthanc import USER as PACS_USER
from harness.sites import noise_photo
from schemas.config import DicomConfig
from schemas.dicom import PacsSendState
from tests.center_pair import center_pair, store_analysis
from tests.conftest import CONSULTANT
from tests.pages_helpers import post_form


@pytest.fixture(scope="module")
def pair(tmp_path_factory, orthanc):
    folder = tmp_path_factory.mktemp("pair")
    with center_pair(folder) as pair:
        api = pair.api
        patient_id = api.post("/api/v1/patients", patient_body(), "patient")["meta"]["id"]
        encounter_id = api.post("/api/v1/encounters", encounter_body(patient_id), "encounter")["meta"]["id"]
        wound = api.post(f"/api/v1/patients/{patient_id}/wounds", wound_body(patient_id), "wound")
        photo = api.upload(noise_photo(folder / "photo.jpg", 1, size=(640, 480)), encounter_id)
        store_analysis(pair, encounter_id, [photo["asset"]["id"]], wound_id=wound["meta"]["id"])
        pair.send(encounter_id)
        secret = folder / "pacs-password"
        secret.write_text(PACS_PASSWORD)
        dicom = DicomConfig(
            endpoint=orthanc.dicomweb_url, username=PACS_USER, password_file=str(secret), patient_id_rule="burnedge_id"
        )
        config = msgspec.structs.replace(pair.center_config, dicom=dicom)
        pair.center.pacs = CenterPacsService(pair.center.db, config, pair.center.cases)
        pair.patient_id = patient_id
        yield pair


def test_a_consultant_forwards_the_case_to_the_pacs_as_one_study_and_again_adds_nothing(pair, orthanc):
    with pair.consultant() as consultant:
        page = consultant.get(pair.case_url)
        assert "Send to the hospital's PACS" in page.text and "Not forwarded to the hospital" in page.text
        r = post_form(consultant, f"{pair.case_url}/pacs", {}, from_page=pair.case_url)
        assert r.status_code == 303 and r.headers["location"].endswith("#pacs")
        shown = consultant.get(pair.case_url).text
        assert 'data-pacs-state="sent"' in shown and "5 objects" in shown
        with orthanc.client() as http:
            stats = http.get("/statistics").json()
            assert (stats["CountPatients"], stats["CountStudies"], stats["CountInstances"]) == (1, 1, 5)
            (patient,) = http.get("/patients", params={"expand": "1"}).json()
            assert patient["MainDicomTags"]["PatientID"] == f"BE-{pair.patient_id}"  # the configured rule
            classes = set()
            for instance in http.get("/instances").json():
                ds = dcmread(io.BytesIO(http.get(f"/instances/{instance}/file").content))
                classes.add(ds.SOPClassUID.name)
        assert classes == {
            "VL Photographic Image Storage",
            "Comprehensive 3D SR Storage",
            "Encapsulated STL Storage",
            "Encapsulated PDF Storage",
            "Surface Scan Mesh Storage",
        }
        post_form(consultant, f"{pair.case_url}/pacs", {}, from_page=pair.case_url)
        with orthanc.client() as http:
            assert http.get("/statistics").json()["CountInstances"] == 5
        sends = pair.center.pacs.sends(CONSULTANT, "clinic-test", pair.bundle_id)
        assert [s.state for s in sends] == [PacsSendState.sent] * 2 and sends[0].already_there == 5
        audit = (
            pair.center.db.connection()
            .execute("SELECT action FROM audit_log WHERE action LIKE 'dicom.%' ORDER BY seq")
            .fetchall()
        )
        assert [r[0] for r in audit] == ["dicom.send", "dicom.send"]


def test_a_center_without_a_configured_pacs_offers_no_send(pair):
    configured = pair.center.pacs
    pair.center.pacs = CenterPacsService(pair.center.db, pair.center_config, pair.center.cases)
    try:
        with pair.consultant() as consultant:
            page = consultant.get(pair.case_url).text
            asked = post_form(consultant, f"{pair.case_url}/pacs", {}, from_page=pair.case_url)
        assert "hospital's PACS" not in page and 'id="pacs"' not in page
        assert asked.status_code == 409 and "no PACS is configured" in asked.text  # a hand-made POST: said, not sent
    finally:
        pair.center.pacs = configured


def test_a_stopped_pacs_is_shown_as_failed_with_its_reason_and_nothing_is_marked_as_sent(pair, orthanc):
    orthanc.halt()  # the module's last test: its PACS stays down
    with pair.consultant() as consultant:
        before = len(pair.center.pacs.sends(CONSULTANT, "clinic-test", pair.bundle_id))
        r = post_form(consultant, f"{pair.case_url}/pacs", {}, from_page=pair.case_url)
        assert r.status_code == 303
        shown = consultant.get(pair.case_url).text
        assert 'data-pacs-state="failed"' in shown and "cannot be reached" in shown
    newest, *older = pair.center.pacs.sends(CONSULTANT, "clinic-test", pair.bundle_id)
    assert len(older) == before and newest.state is PacsSendState.failed
    assert "nothing was marked as sent" in newest.error
