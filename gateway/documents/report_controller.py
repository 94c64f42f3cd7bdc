"""The clinical report (PDF) of an encounter."""

from __future__ import annotations

from typing import Annotated

from litestar import Controller, Response, get
from litestar.openapi import ResponseSpec
from litestar.params import HeaderParameter

from base.web.paths import IdPath
from base.web.problems import ONE, problems
from base.web.site import AuthedRequest
from gateway.dependencies import ServicesDep

IfNoneMatch = Annotated[
    str | None, HeaderParameter(name="If-None-Match", description="The ETag of a report you hold: 304 if it is current")
]


class ReportController(Controller):
    path = "/api/v1/encounters/{encounter_id:str}"
    tags = ["reports"]

    @get(
        "/report.pdf",
        sync_to_thread=True,
        summary="The clinical report as of now (made again when the record changes)",
        media_type="application/pdf",
        responses={
            200: ResponseSpec(bytes, media_type="application/pdf", description="The report"),
            304: ResponseSpec(None, description="The report you hold (If-None-Match) is current"),
            **problems(*ONE, 409),
        },
    )
    def report(
        self, encounter_id: IdPath, request: AuthedRequest, services: ServicesDep, if_none_match: IfNoneMatch = None
    ) -> Response[bytes]:
        made = services.reports.make(request.user, encounter_id)
        headers = {"ETag": made.etag, "Cache-Control": "private, no-cache"}
        if if_none_match is not None and made.etag in [t.strip() for t in if_none_match.split(",")]:
            return Response(content=b"", status_code=304, headers=headers)
        headers["Content-Disposition"] = f'inline; filename="burn-report-{encounter_id}.pdf"'
        return Response(content=made.pdf, media_type="application/pdf", headers=headers)
