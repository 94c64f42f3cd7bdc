"""The burn-center page (the link's state and every case on its way or delivered, for staff and the clinic's IT)
and the encounter's confirmation before a case is sent."""

from __future__ import annotations

from litestar import Controller, get, post
from litestar.response import Redirect, Template

from base.web.pages.forms import FormBody, posted_text
from base.web.pages.rendering import page
from base.web.paths import IdPath
from base.web.site import AuthedRequest
from gateway.dependencies import ServicesDep
from gateway.pages.common import posted_version
from gateway.pages.encounter_view import encounter_header
from gateway.transfers.link_pages import transfers_page
from gateway.transfers.send_preview import CONSENT_WORDS, MADE_WHEN_SENT
from schemas.errors import Conflict, VersionMismatch
from schemas.patient import SharingConsent
from schemas.records import RecordKind


class EncounterSendPages(Controller):
    """The encounter page's "send to the burn center" button."""

    path = "/encounters/{encounter_id:str}"
    include_in_schema = False

    @get("/send", sync_to_thread=True)
    def confirm(self, encounter_id: IdPath, request: AuthedRequest, services: ServicesDep) -> Template:
        return _confirmation(request, services, encounter_id)

    @post("/send", sync_to_thread=True, status_code=303)
    def send(
        self, encounter_id: IdPath, request: AuthedRequest, data: FormBody, services: ServicesDep
    ) -> Redirect | Template:
        chosen = posted_text(data, "consent")
        encounter, _ = encounter_header(services, request.user, encounter_id)
        if chosen not in {c.value for c in SharingConsent}:
            problem = "Say whether the patient agreed before the case is sent."
            return _confirmation(request, services, encounter_id, problem, 422)
        try:
            if encounter.data.get("sharing_consent") != chosen:
                changed = {**encounter.data, "sharing_consent": chosen}
                services.records.update(request.user, RecordKind.encounter, encounter_id, changed, posted_version(data))
            services.transfers.send(request.user, encounter_id)
        except (Conflict, VersionMismatch) as exc:
            return _confirmation(request, services, encounter_id, exc.detail, 409, chosen)
        services.run_sync_now()
        return Redirect(path=f"/encounters/{encounter_id}#burn-center", status_code=303)


def _confirmation(request, services, encounter_id: str, problem: str = "", status: int = 200, chosen: str = ""):
    encounter, patient = encounter_header(services, request.user, encounter_id)
    return page(
        request,
        "send_confirm.html",
        status,
        encounter=encounter,
        patient=patient,
        preview=services.transfers.preview(request.user, encounter_id),
        consents=list(SharingConsent),
        consent_words=CONSENT_WORDS,
        refused=SharingConsent.refused,
        made_when_sent=MADE_WHEN_SENT,
        problem=problem,
        chosen=chosen,
    )


class TransferPages(Controller):
    path = "/transfers"
    include_in_schema = False

    @get("/", sync_to_thread=False)
    def transfers(self, request: AuthedRequest, services: ServicesDep) -> Template:
        return transfers_page(request, services)

    @post("/sync-now", sync_to_thread=True, status_code=303)
    def sync_now(self, request: AuthedRequest, services: ServicesDep) -> Redirect:
        services.transfers.status(request.user)  # the same staff check as reading the page
        services.run_sync_now()
        return Redirect(path="/transfers", query_params={"asked": "1"}, status_code=303)
