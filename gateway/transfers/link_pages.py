"""The administrator's forms on the Burn center page that link the clinic to a burn center (gateway/transfers/link.py).

Each write answers 303 back to the page with a confirmation, or the page again with the problem beside the step it
belongs to and nothing stored. Reading the center's keys stores nothing either: the page shows them with their
fingerprint, to be compared by phone before they are enrolled.
"""

from __future__ import annotations

from typing import Annotated, Any

from litestar import Controller, Response, get, post
from litestar.enums import RequestEncodingType
from litestar.params import Body
from litestar.response import Redirect, Template

from base.web.pages.forms import FormBody, posted_text
from base.web.pages.rendering import page
from base.web.pages.uploads import download, uploaded_bytes
from base.web.site import AuthedRequest
from gateway.dependencies import Services, ServicesDep
from schemas.accounts import Role
from schemas.errors import BurnedgeError, Conflict, InvalidInput
from sync.link_card import MAX_CARD_BYTES, CardToCheck, card_json, card_qr_svg

CardForm = Annotated[dict[str, Any], Body(media_type=RequestEncodingType.MULTI_PART)]
DONE = {
    "keys": "This clinic's keys were made. Give the burn center its keys file or let it photograph the QR code.",
    "center": "The burn center's keys were enrolled: what it sends is now trusted, what is sent to it only it can"
    " read.",
    "unlinked": "The burn center was unlinked: nothing more is sent to it or taken from it.",
    "on": "The link is on: the first try starts now. The status below shows when the center answered.",
    "off": "The link is off: cases wait here until it is switched on again.",
}
"""?done= keys -> the confirmation shown after a write."""
NO_PROBLEMS: dict[str, Any] = {
    "keys_problem": "",
    "keys_raw": None,
    "center_problem": "",
    "candidate": None,
    "unlink_problem": "",
    "settings_problem": "",
    "settings_raw": None,
}
"""What the link's forms show when nothing went wrong (a failed write passes its own values)."""


def transfers_page(request: AuthedRequest, services: Services, status: int = 200, **link_state: Any) -> Template:
    """The Burn center page: the link's state, the administrator's steps to link it, every case sent."""
    who = request.user
    link = services.transfers.link.view(who) if who.role is Role.admin else None
    return page(
        request,
        "transfers.html",
        status,
        status=services.transfers.status(who),
        entries=services.transfers.all_transfers(who),
        asked=bool(request.query_params.get("asked")),
        link=link,
        own_qr=card_qr_svg(link.identity) if link and link.identity else None,
        done=DONE.get(request.query_params.get("done", "")),
        **{**NO_PROBLEMS, **link_state},
    )


def _done(key: str) -> Redirect:
    return Redirect(path="/transfers", query_params={"done": key}, status_code=303)


class LinkPages(Controller):
    path = "/transfers/link"
    include_in_schema = False

    @post("/keys", sync_to_thread=True, status_code=303)
    def make_keys(self, request: AuthedRequest, data: FormBody, services: ServicesDep) -> Redirect | Template:
        try:
            services.transfers.link.make_keys(request.user, posted_text(data, "site_id"), posted_text(data, "name"))
        except InvalidInput as exc:
            return transfers_page(request, services, 422, keys_problem=exc.detail, keys_raw=data)
        return _done("keys")

    @get("/site.pub.json", sync_to_thread=True)
    def keys_file(self, request: AuthedRequest, services: ServicesDep) -> Response:
        identity = services.transfers.link.view(request.user).identity
        if identity is None:
            raise InvalidInput("this clinic has no keys yet: make them on the Burn center page first")
        return download(card_json(identity), f"{identity.site_id}.pub.json", "application/json")

    @post("/center", status_code=200)
    async def read_center(self, request: AuthedRequest, data: CardForm, services: ServicesDep) -> Template:
        """The center's keys read from its file or QR photo and shown to be checked; nothing is stored yet."""
        content = await uploaded_bytes(data, "card", MAX_CARD_BYTES)
        try:
            identity = services.transfers.link.read_center(request.user, content)
        except InvalidInput as exc:
            return transfers_page(request, services, 422, center_problem=exc.detail)
        return transfers_page(request, services, candidate=CardToCheck.of(identity))

    @post("/center/enrol", sync_to_thread=True, status_code=303)
    def enrol_center(self, request: AuthedRequest, data: FormBody, services: ServicesDep) -> Redirect | Template:
        card = posted_text(data, "card")
        try:
            services.transfers.link.enrol_center(request.user, card, posted_text(data, "compared") == "yes")
        except (InvalidInput, Conflict) as exc:
            return _center_again(request, services, card, exc)
        return _done("center")

    @post("/center/unlink", sync_to_thread=True, status_code=303)
    def unlink_center(self, request: AuthedRequest, data: FormBody, services: ServicesDep) -> Redirect | Template:
        try:
            services.transfers.link.unlink_center(request.user, posted_text(data, "reason"))
        except InvalidInput as exc:
            return transfers_page(request, services, 422, unlink_problem=exc.detail)
        return _done("unlinked")

    @post("/settings", sync_to_thread=True, status_code=303)
    def settings(self, request: AuthedRequest, data: FormBody, services: ServicesDep) -> Redirect | Template:
        enabled = posted_text(data, "enabled") == "yes"
        try:
            services.transfers.link.set_link(request.user, enabled, posted_text(data, "endpoints"))
        except InvalidInput as exc:
            return transfers_page(request, services, 422, settings_problem=exc.detail, settings_raw=data)
        if enabled:
            services.run_sync_now()
        return _done("on" if enabled else "off")


def _center_again(request: AuthedRequest, services: Services, card: str, exc: BurnedgeError) -> Template:
    """The confirmation again with the problem, when the keys themselves can still be read."""
    try:
        identity = services.transfers.link.read_center(request.user, card.encode())
    except InvalidInput:
        return transfers_page(request, services, exc.status, center_problem=exc.detail)
    return transfers_page(request, services, exc.status, center_problem=exc.detail, candidate=CardToCheck.of(identity))
