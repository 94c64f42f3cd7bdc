"""The consultant's pages: the incoming cases by urgency, one case, and the advice written back."""

from __future__ import annotations

import datetime as dt
from typing import Annotated, Any
from urllib.parse import urlencode

import msgspec
from litestar import Controller, get, post
from litestar.params import Dependency
from litestar.response import Redirect, Template

from base.web.pages.forms import FormBody, FormInvalid, field_errors, form_fields, parse_form
from base.web.pages.rendering import page
from base.web.paths import IdPath, SiteIdPath
from base.web.query import query_struct
from base.web.site import AuthedRequest
from center.pages.case_view import case_view
from schemas.accounts import Role
from schemas.central import CaseFilter, CasePage, CaseState, NoteRequest
from schemas.errors import InvalidInput, PacsFailed
from schemas.transfer import SiteRole, Urgency
from sync.peers import list_peers

CentralServicesDep = Annotated[Any, Dependency(skip_validation=True)]


def age(stored_at: str) -> str:
    """'25 min ago', '3 h ago', '2 days ago': how long the case has waited."""
    try:
        then = dt.datetime.fromisoformat(stored_at)
    except ValueError:
        return stored_at
    minutes = max(0, int((dt.datetime.now(dt.UTC) - then).total_seconds() // 60))
    if minutes < 60:
        return f"{minutes} min ago"
    if minutes < 48 * 60:
        return f"{minutes // 60} h ago"
    return f"{minutes // 1440} days ago"


def _list_view(request, wanted: CaseFilter, shown: CasePage, clinics, problem: str | None) -> dict:
    """What cases.html shows: the page of cases, the filter as chosen, and links to the next and first page."""
    chosen = {k: v for k, v in msgspec.to_builtins(wanted).items() if k not in ("after", "limit") and v}
    query = {**chosen, **({"limit": wanted.limit} if wanted.limit != CaseFilter().limit else {})}
    return {
        "cases": shown.cases,
        "total": shown.total,
        "total_capped": shown.total_capped,
        "wanted": wanted,
        "filtered": bool(chosen.keys() - {"include_superseded"}),
        "clinics": clinics,
        "urgencies": list(Urgency),
        "states": list(CaseState),
        "problem": problem,
        "next_page": f"{request.url.path}?{urlencode({**query, 'after': shown.next_after})}"
        if shown.next_after
        else None,
        "first_page": f"{request.url.path}?{urlencode(query)}" if wanted.after else None,
        "toggle_superseded": urlencode(
            {**chosen, "include_superseded": "false" if wanted.include_superseded else "true"}
        ),
        "age": age,
    }


class CasePages(Controller):
    path = "/"
    include_in_schema = False

    @get("/", sync_to_thread=False)
    def start(self, request: AuthedRequest) -> Redirect:
        return Redirect(path="/admin" if request.user.role == Role.admin else "/cases", status_code=303)

    @get("/cases", sync_to_thread=False)
    def cases(self, request: AuthedRequest, services: CentralServicesDep) -> Template:
        clinics = [p for p in list_peers(services.db) if p.identity.role == SiteRole.clinic]
        try:
            wanted = query_struct(request, CaseFilter)
        except InvalidInput as exc:
            shown = CasePage(cases=[], total=0, next_after=None)
            return page(request, "cases.html", 422, **_list_view(request, CaseFilter(), shown, clinics, exc.detail))
        shown = services.cases.list_cases(request.user, wanted)
        return page(request, "cases.html", **_list_view(request, wanted, shown, clinics, None))

    @get("/cases/{site_id:str}/{bundle_id:str}", sync_to_thread=True)
    def case(
        self, site_id: SiteIdPath, bundle_id: IdPath, request: AuthedRequest, services: CentralServicesDep
    ) -> Template:
        return self._case(request, services, site_id, bundle_id, form_fields(NoteRequest), {}, 200)

    def _case(self, request, services, site_id, bundle_id, fields, errors, status):
        view = case_view(services, request.user, site_id, bundle_id)
        return page(
            request,
            "case.html",
            status,
            view=view,
            fields=fields,
            errors=errors,
            age=age,
            parts=f"/api/v1/cases/{site_id}/{bundle_id}/parts/",
            written=request.query_params.get("written") == "1",
            pacs_sends=services.pacs.sends(request.user, site_id, bundle_id) if services.pacs.configured else None,
        )

    @post("/cases/{site_id:str}/{bundle_id:str}/pacs", sync_to_thread=True, status_code=303)
    def send_to_pacs(
        self,
        site_id: SiteIdPath,
        bundle_id: IdPath,
        request: AuthedRequest,
        data: FormBody,
        services: CentralServicesDep,
    ) -> Redirect:
        """Forward the case to the hospital's PACS; the result, sent or failed with its reason, shows on the page."""
        try:
            services.pacs.send(request.user, site_id, bundle_id)
        except PacsFailed:
            pass  # recorded as failed with its reason, which the case page shows
        return Redirect(path=f"/cases/{site_id}/{bundle_id}#pacs", status_code=303)

    @post("/cases/{site_id:str}/{bundle_id:str}/notes", sync_to_thread=True, status_code=303)
    def write_note(
        self,
        site_id: SiteIdPath,
        bundle_id: IdPath,
        request: AuthedRequest,
        data: FormBody,
        services: CentralServicesDep,
    ) -> Template | Redirect:
        try:
            body = parse_form(NoteRequest, data, fixed={})
        except FormInvalid as exc:
            errors = field_errors(exc.errors)
            return self._case(
                request, services, site_id, bundle_id, form_fields(NoteRequest, raw=data, errors=errors), errors, 422
            )
        services.cases.write_note(request.user, site_id, bundle_id, body)
        return Redirect(path=f"/cases/{site_id}/{bundle_id}", query_params={"written": "1"}, status_code=303)
