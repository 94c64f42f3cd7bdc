"""An analysed encounter to a real Orthanc (Debian's `orthanc` and `orthanc-dicomweb`, started on loopback by the
tests, harness/orthanc.py): from the command line and from the encounter page; one patient and one study with the
photo, the TID 1500 SR (its area read back), the surface and the PDF; a second send adds nothing; a stopped
Orthanc, a 4xx and a partial STOW answer are clear errors, nothing is marked as sent, and a retry stores each object
once."""

from __future__ import annotations

import io

import pytest
from litestar.testing import TestClient
from pydicom import dcmread

from burnedge.cli import main as cli
from harness.orthanc import PASSWORD as PACS_PASSWORD
from harness.orthanc import USER as PACS_USER
from processing.dicom import web
from processing.dicom.measurements import RELIEF_MAX
from processing.dicom.study import Study, build
from schemas.dicom import PacsSendState
from schemas.errors import PacsFailed
from tests.conftest import start_orthanc
from tests.dicom_clinic import Clinic, clinic_toml
from tests.dicom_inputs import study_input
from tests.pages_helpers import post_form, sign_in

AREA = 18.4  # tests/center_pair.py's analysis


def _instances(orthanc) -> list[tuple[str, bytes]]:
    """(SOP Class UID, Part 10 bytes) of every instance Orthanc holds."""
    with orthanc.client() as http:
        out = []
        for instance in http.get("/instances").json():
            data = http.get(f"/instances/{instance}/file").content
            out.append((str(dcmread(io.BytesIO(data)).SOPClassUID), data))
        return out


def _numbers(sr) -> dict[str, tuple[float, str]]:
    """Every NUM item of the SR's tree: concept code -> (value, UCUM unit)."""
    found = {}

    def walk(items):
        for item in items:
            if item.ValueType == "NUM":
                value = item.MeasuredValueSequence[0]
                unit = value.MeasurementUnitsCodeSequence[0].CodeValue
                found[item.ConceptNameCodeSequence[0].CodeValue] = (float(value.NumericValue), unit)
            walk(getattr(item, "ContentSequence", []))

    walk(sr.ContentSequence)
    return found


def test_the_command_line_sends_an_analysed_encounter_as_one_study_and_a_second_send_adds_nothing(
    orthanc, tmp_path, capsys
):
    clinic = Clinic(tmp_path, orthanc.dicomweb_url)
    with TestClient(clinic.app) as http:
        encounter_id = clinic.analysed_encounter(http)
    toml = clinic_toml(clinic.config, tmp_path)
    assert cli(["--config", str(toml), "export", "dicom", encounter_id, "--out", str(tmp_path / "study")]) == 0
    files = sorted(p.name for p in (tmp_path / "study").iterdir())
    assert len(files) == 5 and all(dcmread(tmp_path / "study" / f).PatientID == "MRN-77" for f in files)

    assert cli(["--config", str(toml), "export", "dicom", encounter_id, "--to", "config"]) == 0
    with orthanc.client() as http:
        stats = http.get("/statistics").json()
        assert (stats["CountPatients"], stats["CountStudies"], stats["CountInstances"]) == (1, 1, 5)
        (patient,) = http.get("/patients", params={"expand": "1"}).json()
        assert patient["MainDicomTags"]["PatientID"] == "MRN-77"
        assert patient["MainDicomTags"]["PatientName"] == "Patient^Test"
    held = dict(_instances(orthanc))
    assert set(held) == {
        "1.2.840.10008.5.1.4.1.1.77.1.4",  # VL Photographic Image
        "1.2.840.10008.5.1.4.1.1.88.34",  # Comprehensive 3D SR
        "1.2.840.10008.5.1.4.1.1.104.3",  # Encapsulated STL
        "1.2.840.10008.5.1.4.1.1.104.1",  # Encapsulated PDF
        "1.2.840.10008.5.1.4.1.1.68.1",  # Surface Scan Mesh
    }
    photo = dcmread(io.BytesIO(held["1.2.840.10008.5.1.4.1.1.77.1.4"]))
    assert photo.file_meta.TransferSyntaxUID == "1.2.840.10008.1.2.4.50"  # the camera's JPEG, not re-encoded
    assert photo.PixelData[:0] == b"" and (tmp_path / "photo.jpg").read_bytes() in bytes(photo.PixelData)
    assert photo.ImageLaterality == "L" and photo.AnatomicRegionSequence[0].CodeValue == "14975008"  # forearm
    sr = dcmread(io.BytesIO(held["1.2.840.10008.5.1.4.1.1.88.34"]))
    numbers = _numbers(sr)
    assert numbers["42798000"] == (AREA, "cm2")  # SNOMED CT Area
    assert numbers[RELIEF_MAX.value] == (1.6, "mm") and "131197000" not in numbers  # relief is never "Depth"
    assert sr.CurrentRequestedProcedureEvidenceSequence[0].ReferencedSeriesSequence[0].ReferencedSOPSequence[
        0
    ].ReferencedSOPInstanceUID == str(photo.SOPInstanceUID)
    pdf = dcmread(io.BytesIO(held["1.2.840.10008.5.1.4.1.1.104.1"]))
    assert bytes(pdf.EncapsulatedDocument).startswith(b"%PDF")
    mesh = dcmread(io.BytesIO(held["1.2.840.10008.5.1.4.1.1.68.1"]))
    assert mesh.NumberOfSurfaces == 2 and mesh.SurfaceSequence[1].SegmentedPropertyTypeCodeSequence[0].CodeValue == (
        "48333001"  # the burn, as Orthanc keeps it
    )

    assert cli(["--config", str(toml), "export", "dicom", encounter_id, "--to", "config"]) == 0
    with orthanc.client() as http:
        again = http.get("/statistics").json()
        assert (again["CountPatients"], again["CountStudies"], again["CountInstances"]) == (1, 1, 5)
    sends = clinic.services.dicom.sends(None, encounter_id)
    assert [s.state for s in sends] == [PacsSendState.sent, PacsSendState.sent]
    assert (sends[0].instances, sends[0].already_there) == (5, 5)  # the newest: everything was there already
    actions = [
        r[0]
        for r in clinic.services.db.connection().execute(
            "SELECT action FROM audit_log WHERE record_id = ? AND action LIKE 'dicom.%' ORDER BY seq", (encounter_id,)
        )
    ]
    assert actions == ["dicom.export", "dicom.send", "dicom.send"]
    capsys.readouterr()


def test_the_encounter_page_sends_and_a_stopped_pacs_is_a_clear_error_with_nothing_marked_as_sent(tmp_path):
    orthanc = start_orthanc()
    try:
        clinic = Clinic(tmp_path, orthanc.dicomweb_url)
        with TestClient(clinic.app) as http:
            encounter_id = clinic.analysed_encounter(http)
            sign_in(http, "clin", next=f"/encounters/{encounter_id}")
            page = http.get(f"/encounters/{encounter_id}")
            assert "Send to the hospital's PACS" in page.text and "Not sent to the hospital" in page.text
            sent = post_form(http, f"/encounters/{encounter_id}/pacs", {}, from_page=f"/encounters/{encounter_id}")
            assert sent.status_code == 303 and sent.headers["location"].endswith("#pacs")
            shown = http.get(f"/encounters/{encounter_id}").text
            assert 'data-pacs-state="sent"' in shown and "5 objects" in shown
            with orthanc.client() as pacs:
                assert pacs.get("/statistics").json()["CountInstances"] == 5

            orthanc.halt()
            r = post_form(http, f"/encounters/{encounter_id}/pacs", {}, from_page=f"/encounters/{encounter_id}")
            assert r.status_code == 303
            shown = http.get(f"/encounters/{encounter_id}").text
            assert 'data-pacs-state="failed"' in shown and "cannot be reached" in shown
            newest, first = clinic.services.dicom.sends(None, encounter_id)
            assert newest.state is PacsSendState.failed and "nothing was marked as sent" in newest.error
            assert first.state is PacsSendState.sent
    finally:
        orthanc.stop()


def test_without_a_configured_pacs_the_page_offers_no_send(tmp_path):
    clinic = Clinic(tmp_path, "")
    with TestClient(clinic.app) as http:
        encounter_id = clinic.analysed_encounter(http)
        sign_in(http, "clin", next=f"/encounters/{encounter_id}")
        page = http.get(f"/encounters/{encounter_id}").text
        assert "hospital's PACS" not in page and 'id="pacs"' not in page
        url = f"/encounters/{encounter_id}"
        asked = post_form(http, f"{url}/pacs", {}, from_page=url)  # a hand-made POST: said, nothing recorded
        assert asked.status_code == 409 and "no PACS is configured" in asked.text
    assert clinic.services.dicom.sends(None, encounter_id) == []
    with pytest.raises(Exception, match="no PACS is configured"):
        clinic.services.dicom.send(None, encounter_id)


def test_a_partial_stow_answer_or_a_4xx_is_a_clear_error_and_a_retry_stores_each_object_once():
    orthanc = start_orthanc()
    try:
        target = web.Endpoint(orthanc.dicomweb_url, PACS_USER, PACS_PASSWORD, timeout_s=20)
        study = build(study_input())
        stranger = build(study_input()).instances[-1]  # another encounter's mesh: Orthanc refuses it here
        with pytest.raises(PacsFailed, match=r"stored only part of the study: 1 of 4 objects refused") as partial:
            web.send(Study(study.study_uid, study.instances[:3] + [stranger]), target)
        assert "nothing was marked as sent" in partial.value.detail
        wrong = web.Endpoint(orthanc.dicomweb_url, PACS_USER, "not the password")
        with pytest.raises(PacsFailed, match=r"refused the credentials \(401\)"):
            web.send(study, wrong)
        with pytest.raises(PacsFailed, match=r"refused the request \(404: Unknown resource\)"):
            web.send(study, web.Endpoint(orthanc.dicomweb_url + "/no-such-root", PACS_USER, PACS_PASSWORD))
        done = web.send(study, target)
        assert (done.instances, done.already_there) == (7, 3)  # the three the partial send stored
        with orthanc.client() as http:
            stats = http.get("/statistics").json()
        assert (stats["CountStudies"], stats["CountInstances"]) == (1, 7)  # each object once; the stranger refused
    finally:
        orthanc.stop()
