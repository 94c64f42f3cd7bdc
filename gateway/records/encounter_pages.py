"""The encounter pages: the overview (calculators, recommendations, burn center), the record parts as forms with
the API's validation and optimistic concurrency, the recommendation acts and the transfer to the burn center."""

from __future__ import annotations

from typing import Annotated

import msgspec
from litestar import Controller, get, post
from litestar.params import QueryParameter
from litestar.response import Redirect, Template

from base.web.pages.forms import FormBody, form_fields
from base.web.pages.forms_fields import with_warnings
from base.web.pages.rendering import clinic_clock, page
from base.web.paths import IdPath
from base.web.site import AuthedRequest
from gateway.dependencies import ServicesDep
from gateway.pages.advice import read_on_opening
from gateway.pages.common import (
    may_write,
    parse_or_errors,
    posted_text,
    posted_version,
    save_part,
    saved_first,
    service_errors,
)
from gateway.pages.encounter_summary import encounter_summary
from gateway.pages.encounter_view import (
    FORM_PAGES,
    PART_PAGES,
    PART_TITLES,
    encounter_header,
    encounter_view,
    older_fields,
    older_shown,
    older_values,
)
from processing.clinical.assessment import age_at_injury
from processing.clinical.vital_ranges import unusual_vitals
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


def _stored(services, who, kind: RecordKind, encounter_id: str) -> Record | None:
    try:
        return services.records.get(who, kind, encounter_id)
    except NotFound:
        return None


class EncounterPages(Controller):
    path = "/encounters/{encounter_id:str}"
    include_in_schema = False

    @get("/", sync_to_thread=False)
    def overview(
        self, encounter_id: IdPath, request: AuthedRequest, services: ServicesDep, saved: Saved = ""
    ) -> Template:
        return self._overview(request, services, encounter_id, saved=saved)

    def _overview(self, request, services, encounter_id, status=200, saved="", act_problem=None, act_reason=""):
        """The overview; act_problem: (recommendation key, why the accept or decline was not stored)."""
        view = encounter_view(services, request.user, encounter_id)
        new_advice = read_on_opening(services, request.user, encounter_id)
        return page(
            request,
            "encounter.html",
            status,
            view=view,
            summary=encounter_summary(view, len(new_advice)),
            new_advice=new_advice,
            tab="overview",
            saved=PART_TITLES.get(PART_PAGES.get(saved), "Burn chart" if saved == "burn-chart" else ""),
            part_pages=PART_PAGES,
            part_titles=PART_TITLES,
            act_problem=act_problem,
            act_reason=act_reason,
            pacs_sends=services.dicom.sends(request.user, encounter_id) if services.dicom.configured else None,
        )

    @get("/parts/{slug:str}", sync_to_thread=False)
    def part_form(self, encounter_id: IdPath, slug: str, request: AuthedRequest, services: ServicesDep) -> Template:
        kind = _slug(slug)
        encounter, patient = encounter_header(services, request.user, encounter_id)
        record = _stored(services, request.user, kind, encounter_id)
        struct, clock, skip = RECORD_TYPES[kind], clinic_clock(request), SKIP | older_fields(kind)
        if record is None:
            fields = form_fields(struct, raw={"assessed_at": clock.now_input()}, skip=skip, clock=clock)
        else:
            value = msgspec.convert(record.data, struct)
            fields = with_warnings(
                form_fields(struct, value=value, skip=skip, clock=clock), _unusual(kind, value, encounter, patient)
            )
        return self._form(request, encounter, patient, slug, kind, fields, record, {}, None, 200)

    @post("/parts/{slug:str}", sync_to_thread=True, status_code=303)
    def save(
        self, encounter_id: IdPath, slug: str, request: AuthedRequest, data: FormBody, services: ServicesDep
    ) -> Template | Redirect:
        kind = _slug(slug)
        encounter, patient = encounter_header(services, request.user, encounter_id)
        struct, clock, skip = RECORD_TYPES[kind], clinic_clock(request), SKIP | older_fields(kind)
        version = posted_version(data)
        stored = _stored(services, request.user, kind, encounter_id) if older_fields(kind) else None
        fixed = {"encounter_id": encounter_id, **older_values(kind, stored.data if stored else None)}
        confirmed = posted_text(data, CONFIRM) == "yes"
        data = {name: value for name, value in data.items() if name != CONFIRM}  # not a field of the part
        body, errors = parse_or_errors(struct, data, fixed, clock.tz)
        conflict = None
        unusual = _unusual(kind, body, encounter, patient) if not errors else {}
        to_confirm = bool(unusual) and not confirmed
        if not errors and not to_confirm:
            try:
                save_part(services, request.user, kind, encounter_id, body, version)
                return Redirect(path=f"/encounters/{encounter_id}", query_params={"saved": slug}, status_code=303)
            except VersionMismatch as exc:
                conflict = exc
            except InvalidInput as exc:
                errors = service_errors(exc)
        fields = with_warnings(form_fields(struct, raw=data, errors=errors, skip=skip, clock=clock), unusual)
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
                saved_first(conflict, clock),
                409,
                posted_version=version,
            )
        return self._form(
            request,
            encounter,
            patient,
            slug,
            kind,
            fields,
            None,
            errors,
            None,
            422,
            posted_version=version,
            kept=stored,
            unusual=to_confirm,
        )

    def _form(
        self,
        request,
        encounter,
        patient,
        slug,
        kind,
        fields,
        record,
        errors,
        conflict,
        status,
        posted_version=None,
        kept: Record | None = None,
        unusual: bool = False,
    ):
        """The part's form page; `kept`: the stored record whose older fields are shown read-only (default: record)."""
        version = record.meta.version if record is not None else (posted_version or 0)
        kept = kept or record
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
            older=older_shown(kind, kept.data if kept is not None else None),
            errors=errors,
            conflict=conflict,
            tab=slug,
            may_edit=may_write(request.user, kind),
            unusual=unusual,
        )

    @post("/recommendations", sync_to_thread=True, status_code=303)
    def act(
        self, encounter_id: IdPath, request: AuthedRequest, data: FormBody, services: ServicesDep
    ) -> Template | Redirect:
        """Accept or decline; a refusal (no reason, the advice changed meanwhile) comes back on the overview, beside
        the recommendation, with the reason as typed."""
        body, errors = parse_or_errors(RecommendationAct, data, {})
        problem, status = "; ".join(errors.values()), 422
        if not errors:
            try:
                services.decision_support.act(request.user, encounter_id, body, posted_version(data))
                return Redirect(path=f"/encounters/{encounter_id}", query_params={"saved": "decision"}, status_code=303)
            except VersionMismatch as exc:
                problem, status = exc.detail, 409
            except InvalidInput as exc:
                problem = exc.detail
        key, reason = posted_text(data, "key"), posted_text(data, "reason")
        return self._overview(request, services, encounter_id, status, act_problem=(key, problem), act_reason=reason)


CONFIRM = "confirm_unusual"
"""The checkbox by which the clinician says the values marked unusual are right."""


def _unusual(kind: RecordKind, value, encounter: Record, patient: Record) -> dict[str, str]:
    """Warnings for vital signs outside the usual range for the patient's age (primary survey only)."""
    if kind is not RecordKind.primary_survey or value is None:
        return {}
    try:
        age = age_at_injury(patient.value(), encounter.value())
    except InvalidInput:
        age = None
    return unusual_vitals(value, age)
