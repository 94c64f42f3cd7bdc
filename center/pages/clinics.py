"""The center administrator's "Clinics" page: the center's keys and address to hand to a clinic, a clinic's keys
read from its file or QR photo and enrolled once the fingerprints match, and the clinics enrolled (center/
clinic_links.py). Each write answers 303 with a confirmation, or the page again with the problem and nothing stored.
"""

from __future__ import annotations

from typing import Annotated, Any

from litestar import Controller, Response, get, post
from litestar.enums import RequestEncodingType
from litestar.params import Body, Dependency
from litestar.response import Redirect, Template

from base.web.pages.forms import FormBody, posted_text
from base.web.pages.rendering import page
from base.web.pages.uploads import download, uploaded_bytes
from base.web.paths import SiteIdPath
from base.web.site import AuthedRequest
from schemas.errors import BurnedgeError, Conflict, InvalidInput, NotFound
from sync.link_card import MAX_CARD_BYTES, CardToCheck, card_json, card_qr_svg

CentralServicesDep = Annotated[Any, Dependency(skip_validation=True)]
CardForm = Annotated[dict[str, Any], Body(media_type=RequestEncodingType.MULTI_PART)]
DONE = {
    "enrolled": "The clinic was enrolled: its cases are accepted from now on and the advice written here reaches it."
    " Its administrator now switches the link on at the clinic.",
    "unlinked": "The clinic was unlinked: what it sends from now on is refused; what it sent before stays readable.",
}


def _clinics_page(request: AuthedRequest, services, status: int = 200, **state: Any) -> Template:
    view = services.clinic_links.view(request.user)
    return page(
        request,
        "clinics.html",
        status,
        view=view,
        own_qr=card_qr_svg(view.identity),
        done=DONE.get(request.query_params.get("done", "")),
        **{"candidate": None, "problem": "", "row_problems": {}, **state},
    )


class ClinicPages(Controller):
    path = "/clinics"
    include_in_schema = False

    @get("/", sync_to_thread=False)
    def clinics(self, request: AuthedRequest, services: CentralServicesDep) -> Template:
        return _clinics_page(request, services)

    @get("/site.pub.json", sync_to_thread=False)
    def keys_file(self, request: AuthedRequest, services: CentralServicesDep) -> Response:
        identity = services.clinic_links.view(request.user).identity
        return download(card_json(identity), f"{identity.site_id}.pub.json", "application/json")

    @post("/read", status_code=200)
    async def read(self, request: AuthedRequest, data: CardForm, services: CentralServicesDep) -> Template:
        content = await uploaded_bytes(data, "card", MAX_CARD_BYTES)
        try:
            identity = services.clinic_links.read_clinic(request.user, content)
        except InvalidInput as exc:
            return _clinics_page(request, services, 422, problem=exc.detail)
        return _clinics_page(request, services, candidate=CardToCheck.of(identity))

    @post("/enrol", sync_to_thread=True, status_code=303)
    def enrol(self, request: AuthedRequest, data: FormBody, services: CentralServicesDep) -> Redirect | Template:
        card = posted_text(data, "card")
        try:
            services.clinic_links.enrol_clinic(request.user, card, posted_text(data, "compared") == "yes")
        except (InvalidInput, Conflict) as exc:
            return _enrol_again(request, services, card, exc)
        return Redirect(path="/clinics", query_params={"done": "enrolled"}, status_code=303)

    @post("/{site_id:str}/unlink", sync_to_thread=True, status_code=303)
    def unlink(
        self, site_id: SiteIdPath, request: AuthedRequest, data: FormBody, services: CentralServicesDep
    ) -> Redirect | Template:
        try:
            services.clinic_links.unlink_clinic(request.user, site_id, posted_text(data, "reason"))
        except (InvalidInput, NotFound) as exc:
            return _clinics_page(request, services, exc.status, row_problems={site_id: exc.detail})
        return Redirect(path="/clinics", query_params={"done": "unlinked"}, status_code=303)


def _enrol_again(request: AuthedRequest, services, card: str, exc: BurnedgeError) -> Template:
    try:
        identity = services.clinic_links.read_clinic(request.user, card.encode())
    except InvalidInput:
        return _clinics_page(request, services, exc.status, problem=exc.detail)
    return _clinics_page(request, services, exc.status, problem=exc.detail, candidate=CardToCheck.of(identity))
