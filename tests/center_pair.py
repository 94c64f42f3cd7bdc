"""A clinic and a burn center in this process, for the center's page tests: the clinic's gateway (its API through a
TestClient) records a case and sends it with its own sync round over Zenoh on loopback to the center's endpoint.

A finished 3D analysis is stored the way the gateway's job runner stores one (its record and files), not
reconstructed: a reconstruction takes minutes; tests/test_browser_clinic.py runs one.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import msgspec
from litestar.testing import TestClient

from base import folders
from base.storage import audit
from burnedge.demo_client import GatewayClient
from center.app import CentralServices, create_central_app, open_center_db
from center.endpoint import Endpoint
from gateway.app import create_app
from harness.bodies import now
from harness.processes import PASSWORD, free_port
from schemas.accounts import Role, UserCreate
from schemas.analysis import AnalysisResult, AnalysisStatus, BurnMetrics, ConfidenceRecord, ScaleSummary
from schemas.config import CentralConfig, Config, GatewayConfig, SyncConfig
from schemas.ids import uuid7
from schemas.jobs import BurnAnalysis
from schemas.records import RecordKind
from schemas.transfer import SiteRole
from sync import peers
from sync.keys import init_keys
from tests.conftest import FAST_SECURITY
from tests.dicom_inputs import painted_box
from tests.pages_helpers import sign_in

SURFACE = "surface/burn_surface.glb"


class Pair:
    """The clinic and the center of one test module, the center's endpoint listening."""

    def __init__(self, api: GatewayClient, clinic, clinic_config: Config, center: CentralServices, center_config):
        self.api, self.clinic, self.clinic_config = api, clinic, clinic_config
        self.center, self.center_config = center, center_config
        self.bundle_id = self.case_url = self.parts_url = ""
        """Of the case sent last."""
        self.job_id = ""
        """Of the analysis stored last."""

    def send(self, encounter_id: str) -> str:
        """Send the encounter as it stands and run the clinic's sync round; the case page's URL."""
        sent = self.api.http.post(f"/api/v1/encounters/{encounter_id}/transfers")
        assert sent.status_code in (200, 202), sent.text
        self.bundle_id = sent.json()["bundle_id"]
        self.case_url = f"/cases/clinic-test/{self.bundle_id}"
        self.parts_url = f"/api/v1/cases/clinic-test/{self.bundle_id}/parts/"
        self.sync_round()
        return self.case_url

    def sync_round(self) -> None:
        report = self.clinic.transfers.sync.run_round(force=True)
        assert report is not None and not report.rejected, report

    def note_count(self) -> int:
        return self.center.db.connection().execute("SELECT COUNT(*) FROM notes").fetchone()[0]

    @contextmanager
    def consultant(self) -> Iterator[TestClient]:
        with TestClient(create_central_app(self.center_config, self.center)) as client:
            sign_in(client, "consult", next="/cases")
            yield client


def store_analysis(pair: Pair, encounter_id: str, photo_ids: list[str], wound_id: str | None = None) -> str:
    """A finished analysis (of the wound, when given) as gateway/jobs/runner.py stores it: the burn_analysis record
    and its files."""
    pair.job_id = store_analysis_at(pair.clinic, pair.clinic_config, encounter_id, photo_ids, wound_id)
    return pair.job_id


def store_analysis_at(clinic, config: Config, encounter_id: str, photo_ids: list[str], wound_id: str | None) -> str:
    """store_analysis on any gateway: its services and config."""
    job_id = uuid7()
    result = AnalysisResult(
        status=AnalysisStatus.ok,
        metrics=BurnMetrics(area_cm2=18.4, perimeter_cm=17.2, relief_max_mm=1.6, volume_cm3=0.42, burn_loops=1),
        confidence=ConfidenceRecord(score=0.86, level="high", views_used=8, views_seeing_burn=8),
        scale=ScaleSummary(method="marker", mm_per_unit=1.0, uncertainty_percent=1.5),
        hours_since_injury=3.0,
        provisional=True,
    )
    record = BurnAnalysis(
        encounter_id=encounter_id,
        job_id=job_id,
        assets=photo_ids,
        requested_by="clin",
        requested_at=now().isoformat(),
        completed_at=now().isoformat(),
        result=result,
        wound_id=wound_id,
    )
    folder = folders.analysis_dir(config, job_id)
    (folder / "surface").mkdir(parents=True)
    (folder / SURFACE).write_bytes(painted_box())  # a box in mm, half of it painted as burnt
    (folder / "analysis.json").write_bytes(msgspec.json.encode(result))
    with clinic.db.write() as conn:
        audit.insert_server_record(
            conn,
            kind=RecordKind.burn_analysis,
            record_id=job_id,
            parent_id=encounter_id,
            data=msgspec.json.encode(record),
            action="analysis.store",
        )
    return job_id


@contextmanager
def center_pair(folder: Path) -> Iterator[Pair]:
    """A clinic and a center enrolled with each other, a clinician at the clinic ("clin"), a consultant ("consult",
    "Dr Consultant") and an administrator ("it") at the center; the center's endpoint listens while it is open."""
    port = free_port()
    sync = SyncConfig(center_endpoints=[f"tcp/127.0.0.1:{port}"], connect_timeout_s=5, query_timeout_s=20)
    clinic_config = Config(
        gateway=GatewayConfig(database=str(folder / "clinic.sqlite3")), security=FAST_SECURITY, sync=sync
    )
    center_config = Config(
        central=CentralConfig(database=str(folder / "center.sqlite3"), listen_endpoints=[f"tcp/127.0.0.1:{port}"]),
        security=FAST_SECURITY,
    )
    clinic_keys = init_keys(folders.keys_dir(clinic_config), "clinic-test", SiteRole.clinic, "Test field clinic")
    center_keys = init_keys(
        folders.center_keys_dir(center_config.central), "center-test", SiteRole.center, "Test burn center"
    )
    center_db = open_center_db(center_config.central)
    center = CentralServices.build(center_config, center_db)
    peers.enrol(center_db, clinic_keys.identity, by="it-person")
    for username, role, display in (("consult", Role.consultant, "Dr Consultant"), ("it", Role.admin, "")):
        center.accounts.create_user(
            None, UserCreate(username=username, password=PASSWORD, role=role, display_name=display)
        )
    gateway_app = create_app(clinic_config)
    clinic = gateway_app.state.services
    peers.enrol(clinic.db, center_keys.identity, by="it-person")
    clinic.accounts.create_user(None, UserCreate(username="clin", password=PASSWORD, role=Role.clinician))
    try:
        with TestClient(gateway_app) as http, Endpoint(center_db, center_config.central, center.receiver):
            api = GatewayClient(http=http)
            api.login("clin", PASSWORD)
            yield Pair(api, clinic, clinic_config, center, center_config)
    finally:
        center_db.close()
