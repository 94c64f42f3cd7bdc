"""A clinic gateway for the DICOM tests against a real Orthanc (tests/test_dicom_pacs.py, tests/test_dicom_api.py):
its configuration with a `[dicom]` endpoint and the PACS's credentials, and an analysed encounter made through the
API as a phone and the job runner would make it."""

from __future__ import annotations

from pathlib import Path

from litestar.testing import TestClient

from burnedge.demo_client import GatewayClient
from gateway.app import create_app
from harness.bodies import encounter_body, patient_body, wound_body
from harness.orthanc import PASSWORD as PACS_PASSWORD
from harness.orthanc import USER as PACS_USER
from harness.processes import PASSWORD
from harness.sites import noise_photo
from schemas.accounts import Role, UserCreate
from schemas.config import Config, DicomConfig, GatewayConfig
from tests.center_pair import store_analysis_at
from tests.conftest import FAST_SECURITY


def clinic_config(folder: Path, endpoint: str) -> Config:
    secret = folder / "pacs-password"
    secret.write_text(PACS_PASSWORD + "\n")
    dicom = DicomConfig(endpoint=endpoint, username=PACS_USER, password_file=str(secret), timeout_s=20)
    return Config(gateway=GatewayConfig(database=str(folder / "clinic.sqlite3")), security=FAST_SECURITY, dicom=dicom)


def clinic_toml(config: Config, folder: Path) -> Path:
    d = config.dicom
    path = folder / "burnedge.toml"
    path.write_text(
        f'[gateway]\ndatabase = "{config.gateway.database}"\n'
        f'[dicom]\nendpoint = "{d.endpoint}"\nusername = "{d.username}"\npassword_file = "{d.password_file}"\n'
    )
    return path


class Clinic:
    def __init__(self, folder: Path, endpoint: str):
        self.folder = folder
        self.config = clinic_config(folder, endpoint)
        self.app = create_app(self.config)
        self.services = self.app.state.services
        self.services.accounts.create_user(None, UserCreate(username="clin", password=PASSWORD, role=Role.clinician))

    def analysed_encounter(self, http: TestClient) -> str:
        """A patient with a medical record number, an encounter, a wound of the left forearm, a camera JPEG of it and
        a finished analysis of it (stored as the job runner stores one)."""
        api = GatewayClient(http=http)
        api.login("clin", PASSWORD)
        patient = api.post("/api/v1/patients", patient_body(medical_record_number="MRN-77"), "patient")
        patient_id = patient["meta"]["id"]
        encounter_id = api.post("/api/v1/encounters", encounter_body(patient_id), "encounter")["meta"]["id"]
        wound = api.post(f"/api/v1/patients/{patient_id}/wounds", wound_body(patient_id), "wound")
        photo = api.upload(noise_photo(self.folder / "photo.jpg", 1, size=(640, 480)), encounter_id)
        store_analysis_at(self.services, self.config, encounter_id, [photo["asset"]["id"]], wound["meta"]["id"])
        http.headers.pop("Authorization", None)
        return encounter_id
