"""The API of the send to the hospital's PACS (docs/dicom.md): send an encounter's study, and list its sends with
their state, as the encounter page's "Send to the hospital's PACS" does. The study always goes to [dicom] endpoint:
no client names where patient data is sent."""

from __future__ import annotations

from litestar import Controller, Response, get, post
from litestar.openapi import ResponseSpec

from base.web.paths import IdPath
from base.web.problems import ONE, problems
from base.web.site import AuthedRequest
from gateway.dependencies import ServicesDep
from schemas.dicom import PacsSend


class PacsController(Controller):
    path = "/api/v1/encounters/{encounter_id:str}/pacs-sends"
    tags = ["dicom"]

    @post(
        "/",
        sync_to_thread=True,
        status_code=201,
        summary="Send the encounter to the hospital's PACS as one DICOM study (STOW-RS, checked by QIDO-RS)",
        description="Photos, the measurements (TID 1500 SR), the surface (mesh and STL) and the PDF report. Sending "
        "again replaces what the PACS holds and adds nothing. 502: the PACS was unreachable, refused the study or "
        "stored only part of it; the failed send is recorded (GET lists it) and nothing is marked as sent.",
        responses={
            201: ResponseSpec(PacsSend, description="Every object stored and found again at the PACS"),
            **problems(*ONE, 409, 502),
        },
    )
    def send(self, encounter_id: IdPath, request: AuthedRequest, services: ServicesDep) -> Response[PacsSend]:
        sent = services.dicom.send_configured(request.user, encounter_id)
        return Response(sent, status_code=201, headers={"Location": f"/api/v1/encounters/{encounter_id}/pacs-sends"})

    @get(
        "/",
        sync_to_thread=True,
        summary="The encounter's sends to the hospital's PACS, newest first, with their state",
        responses=problems(*ONE),
    )
    def sends(self, encounter_id: IdPath, request: AuthedRequest, services: ServicesDep) -> list[PacsSend]:
        return services.dicom.sends(request.user, encounter_id)
