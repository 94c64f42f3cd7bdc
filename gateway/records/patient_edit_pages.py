"""Correcting a patient (the New patient form, filled from the current version), withdrawing one with a reason, and
restoring a withdrawn one. Every change is a new version; the earlier ones stay in the record's history."""

from __future__ import annotations

import msgspec
from litestar import Controller, get, post
from litestar.response import Redirect, Template

from base.web.pages.forms import FormBody, form_fields, posted_text
from base.web.pages.rendering import clinic_clock, page, patient_name
from base.web.paths import IdPath
from base.web.site import AuthedRequest
from gateway.dependencies import ServicesDep
from gateway.pages.common import parse_or_errors, posted_version, saved_first, service_errors
from gateway.records.patient_pages import PATIENT_SKIP
from schemas.errors import InvalidInput, VersionMismatch
from schemas.patient import Patient
from schemas.records import Record, RecordKind

WITHDRAWN = "This record was withdrawn: restore it first to correct it."


def _patient_form(request, patient: Record, fields, version: int, errors: dict, status: int = 200, conflict=None):
    return page(
        request,
        "patient_edit.html",
        status,
        patient=patient,
        name=patient_name(patient.data),
        fields=fields,
        version=version,
        errors=errors,
        conflict=conflict,
    )


def _withdraw_form(request, services, patient: Record, errors: dict, status: int = 200, reason: str = ""):
    who = request.user
    encounters = services.records.list_records(who, RecordKind.encounter, parent_id=patient.meta.id, limit=None)
    wounds = services.records.list_records(who, RecordKind.wound, parent_id=patient.meta.id, limit=None)
    return page(
        request,
        "patient_withdraw.html",
        status,
        patient=patient,
        name=patient_name(patient.data),
        encounters=len(encounters),
        wounds=len(wounds),
        errors=errors,
        reason=reason,
    )


def _changed_meanwhile(what: str, exc: VersionMismatch) -> str:
    who = exc.current.meta.updated_by if isinstance(exc.current, Record) else "someone"
    return f"{what}: {who} changed this record while you were deciding. Check it as it is now, then try again."


class PatientEditPages(Controller):
    path = "/patients/{patient_id:str}"
    include_in_schema = False

    @get("/edit", sync_to_thread=False)
    def edit_form(self, patient_id: IdPath, request: AuthedRequest, services: ServicesDep) -> Template:
        patient = services.records.get(request.user, RecordKind.patient, patient_id)
        errors = {"": WITHDRAWN} if patient.meta.deleted else {}
        value = msgspec.convert(patient.data, Patient)
        fields = form_fields(Patient, value=value, skip=PATIENT_SKIP)
        return _patient_form(request, patient, fields, patient.meta.version, errors)

    @post("/edit", sync_to_thread=True, status_code=303)
    def save(
        self, patient_id: IdPath, request: AuthedRequest, data: FormBody, services: ServicesDep
    ) -> Template | Redirect:
        patient = services.records.get(request.user, RecordKind.patient, patient_id)
        version = posted_version(data)
        body, errors = parse_or_errors(Patient, data, {"id": patient_id})
        if patient.meta.deleted:
            errors = {"": WITHDRAWN}
        if not errors:
            try:
                services.records.update(request.user, RecordKind.patient, patient_id, body, version)
                return Redirect(path=f"/patients/{patient_id}", status_code=303)
            except VersionMismatch as exc:
                fields = form_fields(Patient, raw=data, skip=PATIENT_SKIP)
                current = exc.current if isinstance(exc.current, Record) else patient
                conflict = saved_first(exc, clinic_clock(request))
                return _patient_form(request, current, fields, current.meta.version, {}, 409, conflict)
            except InvalidInput as exc:  # the service's own checks (a date of birth in the future)
                errors = service_errors(exc)
        fields = form_fields(Patient, raw=data, errors=errors, skip=PATIENT_SKIP)
        return _patient_form(request, patient, fields, version, errors, 422)

    @get("/withdraw", sync_to_thread=False)
    def withdraw_form(self, patient_id: IdPath, request: AuthedRequest, services: ServicesDep) -> Template:
        patient = services.records.get(request.user, RecordKind.patient, patient_id)
        return _withdraw_form(request, services, patient, {})

    @post("/withdraw", sync_to_thread=True, status_code=303)
    def withdraw(
        self, patient_id: IdPath, request: AuthedRequest, data: FormBody, services: ServicesDep
    ) -> Template | Redirect:
        reason = posted_text(data, "reason").strip()
        version = posted_version(data)
        try:
            if not reason:
                raise InvalidInput("Say why this record is withdrawn (for example “entered in error” or “duplicate”).")
            services.records.delete(request.user, RecordKind.patient, patient_id, version, reason)
            return Redirect(path=f"/patients/{patient_id}", status_code=303)
        except VersionMismatch as exc:
            errors, status = {"": _changed_meanwhile("Not withdrawn", exc)}, 409
        except InvalidInput as exc:
            errors, status = {"": exc.detail}, 422
        patient = services.records.get(request.user, RecordKind.patient, patient_id)
        return _withdraw_form(request, services, patient, errors, status, reason)

    @post("/restore", sync_to_thread=True, status_code=303)
    def restore(self, patient_id: IdPath, request: AuthedRequest, data: FormBody, services: ServicesDep) -> Redirect:
        """An update of the withdrawn version restores it (a merged duplicate no longer points at the other)."""
        version = posted_version(data)
        patient = services.records.get(request.user, RecordKind.patient, patient_id)
        body = {**patient.data, "merged_into": None}
        try:
            services.records.update(request.user, RecordKind.patient, patient_id, body, version)
        except VersionMismatch as exc:
            problem = _changed_meanwhile("Not restored", exc)
            return Redirect(path=f"/patients/{patient_id}", query_params={"problem": problem}, status_code=303)
        return Redirect(path=f"/patients/{patient_id}", status_code=303)
