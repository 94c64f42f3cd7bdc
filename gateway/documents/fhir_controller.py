"""The FHIR R4 export of an encounter."""

from __future__ import annotations

from litestar import Controller, Response, get
from litestar.openapi import ResponseSpec

from base.web.paths import IdPath
from base.web.problems import ONE, problems
from base.web.site import AuthedRequest
from gateway.dependencies import ServicesDep
from processing.fhir.bundle import FHIR_JSON


class FhirController(Controller):
    path = "/api/v1/encounters/{encounter_id:str}"
    tags = ["fhir"]

    @get(
        "/fhir",
        sync_to_thread=True,
        summary="The encounter as one FHIR R4 Bundle (collection): patient, burns, %TBSA, wound sizes, files",
        description="Codes, units and what is left out: docs/fhir.md. Files are referenced by URL on this "
        "gateway, with their size and hashes, not embedded.",
        media_type=FHIR_JSON,
        responses={
            200: ResponseSpec(dict, media_type=FHIR_JSON, description="A FHIR R4 Bundle of type collection"),
            **problems(*ONE, 409),
        },
    )
    def fhir(self, encounter_id: IdPath, request: AuthedRequest, services: ServicesDep) -> Response[dict]:
        bundle = services.fhir.export(request.user, encounter_id)
        disposition = f'attachment; filename="burnedge-encounter-{encounter_id}.fhir.json"'
        headers = {"Cache-Control": "private, no-store", "Content-Disposition": disposition}
        return Response(content=bundle, media_type=FHIR_JSON, headers=headers)
