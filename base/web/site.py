"""What a server built on the base provides to the shared handlers (login, accounts, the audit trail, health), and
how handlers receive it."""

from __future__ import annotations

from typing import Annotated, Protocol

from litestar import Request
from litestar.datastructures import State
from litestar.params import Dependency

from base.accounts.permissions import Principal
from base.accounts.service import AccountService
from base.storage.database import Database
from schemas.audit import AuditVerification


class SiteServices(Protocol):
    """The services object a server puts in `app.state.services` and provides as "services"."""

    @property
    def db(self) -> Database:
        """The server's database (health reads it; the audit trail lives in it)."""
        ...

    @property
    def accounts(self) -> AccountService:
        """Logins, sessions, users and devices."""
        ...

    def verify_audit(self, principal: Principal | None) -> AuditVerification:
        """The audit chain checked end to end (principal None: the server's own command line)."""
        ...


def client_address(request: Request) -> str:
    return request.client.host if request.client else "unknown"


SiteServicesDep = Annotated[SiteServices, Dependency(skip_validation=True)]
"""Declared by name ("services"); each server's app factory provides its own object that meets SiteServices."""

AuthedRequest = Request[Principal, str, State]
"""A request the session middleware has authenticated: request.user is the Principal.

Handlers read the principal from here rather than through a second dependency:
resolving a request-bound dependency cost about a third of a record read's throughput.
"""
