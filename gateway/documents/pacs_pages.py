"""The encounter page's "Send to the hospital's PACS" action (shown when [dicom] is configured): the study is
sent at once and the result, sent or failed with its reason, is shown on the encounter page (templates/pacs.html)."""

from __future__ import annotations

from litestar import Controller, post
from litestar.response import Redirect

from base.web.pages.forms import FormBody
from base.web.paths import IdPath
from base.web.site import AuthedRequest
from gateway.dependencies import ServicesDep
from schemas.errors import PacsFailed


class EncounterPacsPages(Controller):
    path = "/encounters/{encounter_id:str}"
    include_in_schema = False

    @post("/pacs", sync_to_thread=True, status_code=303)
    def send(self, encounter_id: IdPath, request: AuthedRequest, data: FormBody, services: ServicesDep) -> Redirect:
        try:
            services.dicom.send_configured(request.user, encounter_id)
        except PacsFailed:
            pass  # recorded as failed with its reason, which the encounter page shows
        return Redirect(path=f"/encounters/{encounter_id}#pacs", status_code=303)
