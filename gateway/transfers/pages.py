"""The burn-center page: the link's state and every case on its way or delivered (staff and the clinic's IT)."""

from __future__ import annotations

from litestar import Controller, get, post
from litestar.response import Redirect, Template

from base.web.pages.rendering import page
from base.web.paths import IdPath
from base.web.site import AuthedRequest
from gateway.dependencies import ServicesDep


class EncounterSendPages(Controller):
    """The encounter page's "send to the burn center" button."""

    path = "/encounters/{encounter_id:str}"
    include_in_schema = False

    @post("/send", sync_to_thread=True, status_code=303)
    def send(self, encounter_id: IdPath, request: AuthedRequest, services: ServicesDep) -> Redirect:
        services.transfers.send(request.user, encounter_id)
        services.run_sync_now()
        return Redirect(path=f"/encounters/{encounter_id}#burn-center", status_code=303)


class TransferPages(Controller):
    path = "/transfers"
    include_in_schema = False

    @get("/", sync_to_thread=False)
    def transfers(self, request: AuthedRequest, services: ServicesDep) -> Template:
        status = services.transfers.status(request.user)
        entries = services.transfers.all_transfers(request.user)
        return page(
            request, "transfers.html", status=status, entries=entries, asked=bool(request.query_params.get("asked"))
        )

    @post("/sync-now", sync_to_thread=True, status_code=303)
    def sync_now(self, request: AuthedRequest, services: ServicesDep) -> Redirect:
        services.transfers.status(request.user)  # the same staff check as reading the page
        services.run_sync_now()
        return Redirect(path="/transfers", query_params={"asked": "1"}, status_code=303)
