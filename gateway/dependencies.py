"""What handlers get injected: the services and the authenticated principal."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Annotated

from litestar import Request
from litestar.datastructures import State
from litestar.params import Dependency

from gateway.services.accounts import AccountService
from gateway.services.analyses import AnalysisService
from gateway.services.assets import AssetService
from gateway.services.frames import FrameService
from gateway.services.permissions import Principal
from gateway.services.records import RecordService
from gateway.services.transfers import TransferService
from gateway.services.uploads import UploadService
from gateway.storage.blobs import MediaStore, media_root
from gateway.storage.database import Database
from schemas.config import Config
from sync.phone_sync import PhoneSync


@dataclass
class Services:
    config: Config
    db: Database
    accounts: AccountService
    records: RecordService
    phone_sync: PhoneSync
    assets: AssetService
    uploads: UploadService
    frames: FrameService
    analyses: AnalysisService
    transfers: TransferService
    run_sync_now: Callable[[], None] = lambda: None
    """Starts a sync round at once (set by the scheduler when [sync] enabled)."""

    @classmethod
    def build(cls, config: Config, db: Database) -> Services:
        records = RecordService(db, config)
        store = MediaStore(media_root(config))
        assets = AssetService(db, config, store)
        return cls(
            config=config,
            db=db,
            accounts=AccountService(db, config.security),
            records=records,
            phone_sync=PhoneSync(records, config.gateway.page_max),
            assets=assets,
            uploads=UploadService(db, config, store, assets),
            frames=FrameService(db, config, assets),
            analyses=AnalysisService(db, config, assets),
            transfers=TransferService(db, config),
        )


def provide_services(request: Request) -> Services:
    return request.app.state.services


def client_address(request: Request) -> str:
    return request.client.host if request.client else "unknown"


ServicesDep = Annotated[Services, Dependency(skip_validation=True)]
"""Declared by name ("services"); the app factory provides it. Not validated: the burn center's server provides
its own services object to the shared account handlers (login, users)."""

AuthedRequest = Request[Principal, str, State]
"""A request the session middleware has authenticated: request.user is the Principal.

Handlers read the principal from here rather than through a second dependency:
resolving a request-bound dependency cost about a third of a record read's throughput.
"""
