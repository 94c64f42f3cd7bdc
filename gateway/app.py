"""The app factory: one place that wires config, storage, services and controllers."""

from __future__ import annotations

from litestar import Litestar
from litestar.datastructures import State
from litestar.di import Provide
from litestar.openapi import OpenAPIConfig

from base import __version__
from base.folders import keys_dir
from base.web.account_controllers import AdminController, AuthController
from base.web.authentication import session_auth
from base.web.errors import EXCEPTION_HANDLERS
from base.web.health import health
from base.web.openapi import ClosedStructSchemaPlugin
from base.web.pages.api_docs import offline_openapi_plugins
from base.web.pages.assets import static_files
from base.web.pages.clinic_time import CLOCK_KEY, ClinicClock
from base.web.pages.pairing_link import APP_PATH_KEY, FINGERPRINT_KEY
from base.web.pages.protection import csrf_protection, security_headers
from base.web.pages.rendering import NAV_KEY, NOTICE_KEY, SITE_NAME_KEY, template_config
from gateway.analyses.controller import AnalysisController
from gateway.analyses.model_controller import ModelController
from gateway.capture.asset_controller import AssetController
from gateway.capture.settings_controller import CaptureSettingsController
from gateway.capture.upload_controller import UploadController
from gateway.dependencies import Services, provide_services
from gateway.documents.fhir_controller import FhirController
from gateway.documents.pacs_controller import PacsController
from gateway.documents.report_controller import ReportController
from gateway.https_gate import PlainHttpGate
from gateway.jobs.supervisor import Workers
from gateway.pages import NAV, SITE_NAME
from gateway.pages.advice import advice_notice
from gateway.phones.app_routes import APP_PATH, CompanionAppController
from gateway.phones.controller import SyncController
from gateway.reactions import ANALYSIS_STORED
from gateway.records.controller import EncounterController, PatientController
from gateway.records.decision_support_controller import DecisionSupportController
from gateway.records.parts_controller import PART_CONTROLLERS
from gateway.scheduler import start_scheduler
from gateway.site import TEMPLATE_DIRS, page_controllers
from gateway.storage.database import Database
from gateway.tls import ensure_ca, fingerprint, https_wanted
from gateway.transfers.controller import TransferController
from gateway.wounds.controller import PatientHealingController, PatientWoundsController, WoundController
from schemas.config import Config


def create_app(config: Config, *, start_workers: bool = False) -> Litestar:
    """The gateway; `start_workers` also runs config.jobs.workers analysis worker processes beside it (serve)."""
    db = Database.from_config(config.gateway)
    db.migrate()
    services = Services.build(config, db)
    workers = Workers(config, ANALYSIS_STORED) if start_workers and config.jobs.workers else None
    clock = ClinicClock.from_setting(config.gateway.timezone, config.gateway.clock_skew_s)
    return Litestar(
        route_handlers=[
            health,
            AuthController,
            AdminController,
            PatientController,
            EncounterController,
            PatientWoundsController,
            PatientHealingController,
            WoundController,
            *PART_CONTROLLERS,
            DecisionSupportController,
            ReportController,
            FhirController,
            PacsController,
            SyncController,
            CompanionAppController,
            UploadController,
            AssetController,
            CaptureSettingsController,
            AnalysisController,
            ModelController,
            TransferController,
            static_files(),
            *page_controllers(),
        ],
        dependencies={
            "services": Provide(provide_services, sync_to_thread=False, use_cache=True),
        },
        middleware=[*_plain_http_gate(config), security_headers, csrf_protection, session_auth],
        template_config=template_config(TEMPLATE_DIRS, clock),
        exception_handlers=EXCEPTION_HANDLERS,
        openapi_config=OpenAPIConfig(
            title="burnedge gateway",
            version=__version__,
            description="Clinical record, capture and sync API of a burnedge clinic gateway. "
            "Outputs are decision support, never autonomous decisions.",
            path="/schema",
            render_plugins=offline_openapi_plugins(),
        ),
        state=State(
            {
                "services": services,
                SITE_NAME_KEY: SITE_NAME,
                NAV_KEY: NAV,
                NOTICE_KEY: lambda principal: advice_notice(services, principal),
                CLOCK_KEY: clock,
                APP_PATH_KEY: f"{APP_PATH}/",
                FINGERPRINT_KEY: _authority_fingerprint(config),
            }
        ),
        on_startup=[lambda app: _start_background(app, services, workers)],
        on_shutdown=[lambda app: _stop_background(app, workers), lambda app: db.close()],
        request_max_body_size=config.gateway.max_body_bytes,
        plugins=[ClosedStructSchemaPlugin()],
    )


def _authority_fingerprint(config: Config) -> str | None:
    """The gateway's own certificate authority (made now on first start) when it serves HTTPS."""
    if not https_wanted(config.gateway):
        return None
    return fingerprint(ensure_ca(keys_dir(config), config.report.clinic_name))


def _plain_http_gate(config: Config) -> list:
    """Plain HTTP answers other machines only what a phone needs before it trusts the HTTPS address."""
    return [PlainHttpGate(config.gateway)] if https_wanted(config.gateway) else []


def _start_background(app: Litestar, services: Services, workers: Workers | None) -> None:
    if workers is not None:
        workers.start()
    app.state.scheduler = start_scheduler(services, workers)


def _stop_background(app: Litestar, workers: Workers | None) -> None:
    # Wait for a running periodic job: the database's connections are closed next, and closing one a job's thread
    # is still using crashes the process (SQLite).
    app.state.scheduler.shutdown(wait=True)
    if workers is not None:
        workers.stop()
