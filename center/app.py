"""The burn center's server: the consultants' HTTP API and, started with it, the Zenoh endpoint clinics call."""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Annotated

import uvicorn
from apscheduler.schedulers.background import BackgroundScheduler
from litestar import Controller, Litestar, get, post
from litestar.datastructures import State
from litestar.di import Provide
from litestar.openapi import OpenAPIConfig
from litestar.params import Dependency, FromPath, JSONBody
from litestar.response import Stream

from base import __version__
from base.accounts.permissions import Principal, require_admin
from base.accounts.service import AccountService
from base.folders import center_keys_dir, center_store_dir
from base.storage import audit
from base.storage.database import Database
from base.storage.dialect import is_postgres
from base.storage.postgres import AnyDatabase, PostgresDatabase
from base.web.account_controllers import AdminController, AuthController
from base.web.authentication import session_auth
from base.web.errors import EXCEPTION_HANDLERS
from base.web.health import health
from base.web.pages.api_docs import offline_openapi_plugins
from base.web.pages.assets import static_files
from base.web.pages.protection import csrf_protection, security_headers
from base.web.pages.rendering import NAV_KEY, SITE_NAME_KEY, template_config
from base.web.paths import IdPath, SiteIdPath
from base.web.query import query_struct
from base.web.site import AuthedRequest
from center.cases import CaseService
from center.clinic_links import ClinicLinks
from center.endpoint import Endpoint
from center.pacs import CenterPacsService
from center.pages import NAV, SITE_NAME, TEMPLATES, page_controllers
from center.receiver import Receiver
from center.storage.migrations import CENTER_STEPS, CENTRAL_SET, central_migrations
from schemas.accounts import Role
from schemas.audit import AuditVerification
from schemas.base import utcnow
from schemas.central import CaseDetail, CaseFilter, CasePage, NoteRequest, NoteStatus, RejectionItem
from schemas.config import CentralConfig, Config
from schemas.errors import Forbidden
from schemas.transfer import Peer
from sync import peers
from sync.keys import SiteKeys, load_keys

log = logging.getLogger("burnedge.central")


def open_center_db(central: CentralConfig) -> AnyDatabase:
    """The configured database, its schema brought up to date (several workers may start together)."""
    if is_postgres(central.database):
        db = PostgresDatabase(central.database, max_connections=central.database_connections)
        try:
            db.migrate(CENTRAL_SET, CENTER_STEPS)
        except BaseException:
            db.close()
            raise
        return db
    db = Database(central.database)
    db.migrate(central_migrations)
    return db


@dataclass
class CentralServices:
    """What the center's handlers get injected as `services`; it meets base.web.site.SiteServices for the shared
    account, audit and health handlers."""

    config: Config
    db: AnyDatabase
    keys: SiteKeys
    accounts: AccountService
    cases: CaseService
    receiver: Receiver
    clinic_links: ClinicLinks
    pacs: CenterPacsService

    @classmethod
    def build(cls, config: Config, db: AnyDatabase) -> CentralServices:
        store_dir = center_store_dir(config.central)
        keys = load_keys(center_keys_dir(config.central))
        cases = CaseService(db, keys, store_dir)
        return cls(
            config=config,
            db=db,
            keys=keys,
            accounts=AccountService(db, config.security),
            cases=cases,
            receiver=Receiver(db, config.central, keys, store_dir),
            clinic_links=ClinicLinks(db, keys, config.central),
            pacs=CenterPacsService(db, config, cases),
        )

    def verify_audit(self, principal: Principal | None) -> AuditVerification:
        """The center's own chain; a center holds no anchor of its own (it signs the clinics')."""
        if principal is not None:
            require_admin(principal, "read_audit")
        with self.db.read() as conn:
            return audit.verify(conn, None, served_records=False)


CentralDep = Annotated["CentralServices", Dependency(skip_validation=True)]


class CaseController(Controller):
    path = "/api/v1/cases"
    tags = ["cases"]

    @get(
        "/",
        sync_to_thread=False,
        summary="Incoming cases, a page at a time: awaiting advice first, then by urgency, oldest first",
        description="Query parameters, all optional: urgency, site_id, state (awaiting, advised, superseded), "
        "include_superseded, received_from and received_to (YYYY-MM-DD, UTC), limit (1-200, default 50), after "
        "(the previous page's next_after). Each given filter must match.",
    )
    def list_cases(self, request: AuthedRequest, services: CentralDep) -> CasePage:
        return services.cases.list_cases(request.user, query_struct(request, CaseFilter))

    @get("/{site_id:str}/{bundle_id:str}", sync_to_thread=False, summary="A case: summary, parts, versions, notes")
    def case(self, site_id: SiteIdPath, bundle_id: IdPath, request: AuthedRequest, services: CentralDep) -> CaseDetail:
        return services.cases.case(request.user, site_id, bundle_id)

    @get("/{site_id:str}/{bundle_id:str}/parts/{name:path}", sync_to_thread=True, summary="One file of a case")
    def part(
        self, site_id: SiteIdPath, bundle_id: IdPath, name: FromPath[str], request: AuthedRequest, services: CentralDep
    ) -> Stream:
        pieces, media_type, size = services.cases.part_stream(request.user, site_id, bundle_id, name.lstrip("/"))
        return Stream(pieces, media_type=media_type, headers={"Content-Length": str(size)})

    @post(
        "/{site_id:str}/{bundle_id:str}/notes",
        sync_to_thread=True,
        status_code=201,
        summary="Write advice on a case; it travels to the clinic encrypted and signed",
    )
    def write_note(
        self,
        site_id: SiteIdPath,
        bundle_id: IdPath,
        data: JSONBody[NoteRequest],
        request: AuthedRequest,
        services: CentralDep,
    ) -> NoteStatus:
        return services.cases.write_note(request.user, site_id, bundle_id, data)


class SitesController(Controller):
    path = "/api/v1"
    tags = ["sites"]

    @get("/sites", sync_to_thread=False, summary="Enrolled clinics, with fingerprints and revocations")
    def sites(self, request: AuthedRequest, services: CentralDep) -> list[Peer]:
        if request.user.role not in (Role.admin, Role.consultant):
            raise Forbidden("only administrators and consultants see the enrolled sites")
        return peers.list_peers(services.db)

    @get("/rejections", sync_to_thread=False, summary="What clinics sent that was refused, and why")
    def rejections(self, request: AuthedRequest, services: CentralDep) -> list[RejectionItem]:
        return services.cases.rejections(request.user)


def create_central_app(config: Config, services: CentralServices) -> Litestar:
    return Litestar(
        route_handlers=[
            health,
            AuthController,
            AdminController,
            CaseController,
            SitesController,
            static_files(),
            *page_controllers(),
        ],
        dependencies={"services": Provide(lambda: services, sync_to_thread=False, use_cache=True)},
        middleware=[security_headers, csrf_protection, session_auth],
        template_config=template_config([TEMPLATES]),
        exception_handlers=EXCEPTION_HANDLERS,
        openapi_config=OpenAPIConfig(
            title="burnedge burn center",
            version=__version__,
            path="/schema",
            render_plugins=offline_openapi_plugins(),
            description="Cases received from clinics and consultants' advice back. "
            "Decision support, never autonomous decisions.",
        ),
        state=State({"services": services, SITE_NAME_KEY: SITE_NAME, NAV_KEY: NAV}),
    )


def serve_central(config: Config) -> None:
    """`burnedge central`: the Zenoh endpoint and the consultants' API until stopped."""
    db = open_center_db(config.central)
    try:
        services = CentralServices.build(config, db)
        scheduler = BackgroundScheduler(daemon=True)
        scheduler.add_job(
            services.receiver.drop_stale,
            "interval",
            hours=6,
            args=[config.central.stale_transfer_days],
            id="drop-stale-transfers",
            coalesce=True,
            max_instances=1,
            next_run_time=utcnow(),
        )
        scheduler.start()
        with Endpoint(db, config.central, services.receiver):
            log.info("consultants' API on http://%s:%d", config.central.host, config.central.port)
            uvicorn.run(
                create_central_app(config, services),
                host=config.central.host,
                port=config.central.port,
                log_level="warning",
                access_log=False,
                timeout_graceful_shutdown=5,
            )
        scheduler.shutdown(wait=True)
    finally:
        db.close()
