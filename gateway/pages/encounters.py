"""The encounter pages: the overview (calculators, recommendations, burn center), the record parts as forms with
the API's validation and optimistic concurrency, the recommendation acts and the transfer to the burn center."""

from __future__ import annotations

from typing import Annotated

import msgspec
from litestar import Controller, get, post
from litestar.params import QueryParameter
from litestar.response import Redirect, Template

from base.web.pages.forms import FormBody, field_errors, form_fields
from base.web.pages.rendering import page
from base.web.paths import IdPath
from base.web.site import AuthedRequest
from gateway.dependencies import ServicesDep
from gateway.pages.common import (
    local_now_input,
    may_write,
    parse_or_errors,
    posted_version,
    save_part,
    saved_first,
)
from gateway.pages.encounter_view import FORM_PAGES, PART_PAGES, PART_TITLES, encounter_header, encounter_view
from schemas.decision_support import RecommendationAct
from schemas.errors import InvalidInput, NotFound, VersionMismatch
from schemas.records import RECORD_TYPES, Record, RecordKind

Saved = Annotated[str, QueryParameter(max_length=40, description="The part just saved (a confirmation)")]
SKIP = frozenset({"encounter_id"})


def _slug(slug: str) -> RecordKind:
    kind = FORM_PAGES.get(slug)
    if kind is None:
        raise NotFound(f"an encounter has no part {slug!r}: choose one of {', '.join(FORM_PAGES)}")
    return kind


class EncounterPages(Controller):
    path = "/encounters/{encounter_id:str}"
    include_in_schema = False

    @get("/", sync_to_thread=False)
    def overview(
        self, encounter_id: IdPath, request: AuthedRequest, services: ServicesDep, saved: Saved = ""
    ) -> Template:
        view = encounter_view(services, request.user, encounter_id)
        return page(
            request,
            "encounter.html",
            view=view,
            tab="overview",
            saved=PART_TITLES.get(PART_PAGES.get(saved), "Burn chart" if saved == "burn-chart" else ""),
            part_pages=PART_PAGES,
            part_titles=PART_TITLES,
        )

    @get("/parts/{slug:str}", sync_to_thread=False)
    def part_form(self, encounter_id: IdPath, slug: str, request: AuthedRequest, services: ServicesDep) -> Template:
        kind = _slug(slug)
        encounter, patient = encounter_header(services, request.user, encounter_id)
        try:
            record: Record | None = services.records.get(request.user, kind, encounter_id)
        except NotFound:
            record = None
        struct = RECORD_TYPES[kind]
        if record is None:
            fields = form_fields(struct, raw={"assessed_at": local_now_input()}, skip=SKIP)
        else:
            fields = form_fields(struct, value=msgspec.convert(record.data, struct), skip=SKIP)
        return self._form(request, encounter, patient, slug, kind, fields, record, {}, None, 200)

    @post("/parts/{slug:str}", sync_to_thread=True, status_code=303)
    def save(
        self, encounter_id: IdPath, slug: str, request: AuthedRequest, data: FormBody, services: ServicesDep
    ) -> Template | Redirect:
        kind = _slug(slug)
        encounter, patient = encounter_header(services, request.user, encounter_id)
        struct = RECORD_TYPES[kind]
        version = posted_version(data)
        body, errors = parse_or_errors(struct, data, {"encounter_id": encounter_id})
        conflict = None
        if not errors:
            try:
                save_part(services, request.user, kind, encounter_id, body, version)
                return Redirect(path=f"/encounters/{encounter_id}", query_params={"saved": slug}, status_code=303)
            except VersionMismatch as exc:
                conflict = exc
            except InvalidInput as exc:
                errors = field_errors(exc.errors) if exc.errors else {"": exc.detail}
        fields = form_fields(struct, raw=data, errors=errors, skip=SKIP)
        if conflict is not None:
            current = conflict.current if isinstance(conflict.current, Record) else None
            return self._form(
                request,
                encounter,
                patient,
                slug,
                kind,
                fields,
                current,
                {},
                saved_first(conflict),
                409,
                posted_version=version,
            )
        return self._form(
            request, encounter, patient, slug, kind, fields, None, errors, None, 422, posted_version=version
        )

    def _form(
        self, request, encounter, patient, slug, kind, fields, record, errors, conflict, status, posted_version=None
    ):
        version = record.meta.version if record is not None else (posted_version or 0)
        return page(
            request,
            "part_form.html",
            status,
            encounter=encounter,
            patient=patient,
            slug=slug,
            title=PART_TITLES[kind],
            fields=fields,
            version=version,
            saved_record=record if conflict else None,
            errors=errors,
            conflict=conflict,
            tab=slug,
            may_edit=may_write(request.user, kind),
        )

    @post("/recommendations", sync_to_thread=True, status_code=303)
    def act(self, encounter_id: IdPath, request: AuthedRequest, data: FormBody, services: ServicesDep) -> Redirect:
        body, errors = parse_or_errors(RecommendationAct, data, {})
        if errors:
            raise InvalidInput("; ".join(f"{k or 'form'}: {v}" for k, v in errors.items()))
        services.decision_support.act(request.user, encounter_id, body, posted_version(data))
        return Redirect(path=f"/encounters/{encounter_id}", query_params={"saved": "decision"}, status_code=303)

    @post("/send", sync_to_thread=True, status_code=303)
    def send(self, encounter_id: IdPath, request: AuthedRequest, services: ServicesDep) -> Redirect:
        services.transfers.send(request.user, encounter_id)
        services.run_sync_now()
        return Redirect(path=f"/encounters/{encounter_id}#burn-center", status_code=303)

    @get("/report", sync_to_thread=False)
    def report(self, encounter_id: IdPath, request: AuthedRequest, services: ServicesDep) -> Template:
        encounter, patient = encounter_header(services, request.user, encounter_id)
        return page(request, "report.html", encounter=encounter, patient=patient, tab="report")
