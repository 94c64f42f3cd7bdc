"""The wound forms on the patient page: a nurse or clinician records one of the patient's burns as a wound, and
changes one (its state as it heals or is grafted, its regions, its name). A change made from an older version than
the stored one is refused, with the page showing the current version."""

from __future__ import annotations

from typing import Any

from litestar import Controller, post
from litestar.response import Redirect

from base.web.pages.forms import FormBody
from base.web.paths import IdPath
from base.web.site import AuthedRequest
from gateway.dependencies import ServicesDep
from gateway.pages.common import parse_or_errors, posted_id, posted_version, service_errors
from schemas.errors import InvalidInput, VersionMismatch
from schemas.records import RecordKind
from schemas.wound import Wound


def _wound_form(data: dict[str, Any]) -> dict[str, Any]:
    """The form as the page forms read lists: the multiple choice of regions as rows regions[0], regions[1]..."""
    form = {k: v for k, v in data.items() if k != "regions"}
    regions = data.get("regions", [])
    for i, region in enumerate([regions] if isinstance(regions, str) else regions):
        form[f"regions[{i}]"] = region
    return form


class WoundPages(Controller):
    path = "/"
    include_in_schema = False

    @post("/patients/{patient_id:str}/wounds/new", sync_to_thread=True, status_code=303)
    def create(self, patient_id: IdPath, request: AuthedRequest, data: FormBody, services: ServicesDep) -> Redirect:
        record_id = posted_id(data)
        body, errors = parse_or_errors(Wound, _wound_form(data), {"id": record_id, "patient_id": patient_id})
        if not errors:
            try:
                services.wounds.create(request.user, patient_id, body)
                return Redirect(path=f"/patients/{patient_id}#wound-{record_id}", status_code=303)
            except InvalidInput as exc:
                errors = service_errors(exc)
        return _refused(patient_id, errors)

    @post("/wounds/{wound_id:str}/edit", sync_to_thread=True, status_code=303)
    def change(self, wound_id: IdPath, request: AuthedRequest, data: FormBody, services: ServicesDep) -> Redirect:
        stored = services.records.get(request.user, RecordKind.wound, wound_id)
        patient_id = stored.value().patient_id
        body, errors = parse_or_errors(Wound, _wound_form(data), {"id": wound_id, "patient_id": patient_id})
        if not errors:
            try:
                services.records.update(request.user, RecordKind.wound, wound_id, body, posted_version(data))
                return Redirect(path=f"/patients/{patient_id}#wound-{wound_id}", status_code=303)
            except VersionMismatch as exc:
                errors = {"": f"{exc.detail} (the page now shows the current version)"}
            except InvalidInput as exc:
                errors = service_errors(exc)
        return _refused(patient_id, errors)


def _refused(patient_id: str, errors: dict[str, str]) -> Redirect:
    """The patient page again, saying why nothing was stored."""
    problems = "; ".join(f"{k + ': ' if k else ''}{v}" for k, v in errors.items())
    return Redirect(path=f"/patients/{patient_id}", query_params={"wound_problem": problems}, status_code=303)
