"""Phone sync endpoints: pull the change feed, push queued mutations."""

from __future__ import annotations

from typing import Annotated

from litestar import Controller, get, post
from litestar.params import JSONBody, QueryParameter

from base.web.problems import BODY, SESSION, problems
from base.web.site import AuthedRequest
from gateway.dependencies import ServicesDep
from schemas.sync import ChangesPage, PushRequest, PushResponse


class SyncController(Controller):
    path = "/api/v1/sync"
    tags = ["sync"]

    @get(
        "/changes",
        sync_to_thread=False,
        summary="Record versions after a cursor, oldest first",
        responses=problems(400, *SESSION),
    )
    def changes(
        self,
        request: AuthedRequest,
        services: ServicesDep,
        since: Annotated[int, QueryParameter(ge=0, le=2**63 - 1, description="next_cursor of the previous page")] = 0,
        limit: Annotated[
            int, QueryParameter(ge=1, le=2**63 - 1, description="Page size (capped by the gateway)")
        ] = 200,
    ) -> ChangesPage:
        return services.phone_sync.changes(request.user, since, limit)

    @post(
        "/push",
        sync_to_thread=True,
        status_code=200,
        summary="Apply queued mutations; safe to retry",
        responses=problems(*BODY, *SESSION),
    )
    def push(self, data: JSONBody[PushRequest], request: AuthedRequest, services: ServicesDep) -> PushResponse:
        return services.phone_sync.push(request.user, data.mutations)
