"""Store-and-forward to the burn center: send a case, follow its delivery, read the consultants' advice."""

from __future__ import annotations

from litestar import Controller, Response, get, post
from litestar.openapi import ResponseSpec

from base.web.paths import IdPath
from base.web.problems import ONE, SESSION, problems
from base.web.site import AuthedRequest
from gateway.dependencies import ServicesDep
from schemas.records import Record
from schemas.transfer import OutboxEntry, SyncStatus


class TransferController(Controller):
    path = "/api/v1"
    tags = ["burn center"]

    @post(
        "/encounters/{encounter_id:str}/transfers",
        sync_to_thread=True,
        status_code=202,
        summary="Send the encounter as it stands now to the burn center (encrypted; delivered when a link exists)",
        responses={
            200: ResponseSpec(OutboxEntry, description="This version was already sent: its outbox entry"),
            **problems(*ONE, 409),
        },
    )
    def send(self, encounter_id: IdPath, request: AuthedRequest, services: ServicesDep) -> Response[OutboxEntry]:
        entry = services.transfers.send(request.user, encounter_id)
        if not entry.unchanged:
            services.run_sync_now()
        return Response(entry, status_code=200 if entry.unchanged else 202)

    @get(
        "/encounters/{encounter_id:str}/transfers",
        sync_to_thread=False,
        summary="Versions of this encounter sent to the burn center, and whether each was delivered",
        responses=problems(*ONE),
    )
    def transfers(self, encounter_id: IdPath, request: AuthedRequest, services: ServicesDep) -> list[OutboxEntry]:
        return services.transfers.transfers(request.user, encounter_id)

    @get(
        "/encounters/{encounter_id:str}/consultations",
        sync_to_thread=False,
        summary="The burn center consultants' notes on this encounter (decision support)",
        responses=problems(*ONE),
    )
    def consultations(self, encounter_id: IdPath, request: AuthedRequest, services: ServicesDep) -> list[Record]:
        return services.transfers.consultations(request.user, encounter_id)

    @get(
        "/transfers",
        sync_to_thread=False,
        summary="The outbox: every case sent or waiting, newest first",
        responses=problems(*SESSION),
    )
    def outbox(self, request: AuthedRequest, services: ServicesDep) -> list[OutboxEntry]:
        return services.transfers.all_transfers(request.user)

    @get(
        "/transfers/status",
        sync_to_thread=False,
        summary="The link to the burn center: last round, errors, backoff",
        responses=problems(*SESSION),
    )
    def status(self, request: AuthedRequest, services: ServicesDep) -> SyncStatus:
        return services.transfers.status(request.user)
