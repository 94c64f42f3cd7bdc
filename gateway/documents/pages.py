"""The encounter's report page: open or download the PDF, made afresh (gateway/documents/reports.py)."""

from __future__ import annotations

from litestar import Controller, get
from litestar.response import Template

from base.web.pages.rendering import page
from base.web.paths import IdPath
from base.web.site import AuthedRequest
from gateway.dependencies import ServicesDep
from gateway.pages.encounter_view import encounter_header


class ReportPages(Controller):
    path = "/encounters/{encounter_id:str}"
    include_in_schema = False

    @get("/report", sync_to_thread=False)
    def report(self, encounter_id: IdPath, request: AuthedRequest, services: ServicesDep) -> Template:
        encounter, patient = encounter_header(services, request.user, encounter_id)
        return page(request, "report.html", encounter=encounter, patient=patient, tab="report")
