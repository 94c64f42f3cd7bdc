"""The patient pages: the list with search, a new patient, one patient with encounters and healing, a new
encounter."""

from __future__ import annotations

from typing import Annotated

from litestar import Controller, get, post
from litestar.params import QueryParameter
from litestar.response import Redirect, Template

from base.accounts.permissions import DELETE
from base.web.pages.forms import FormBody, form_fields
from base.web.pages.rendering import clinic_clock, page, patient_name
from base.web.paths import IdPath
from base.web.site import AuthedRequest
from gateway.dependencies import ServicesDep
from gateway.pages.advice import by_patient
from gateway.pages.common import parse_or_errors, posted_id, service_errors
from gateway.pages.healing_view import wound_section
from schemas.accounts import Role
from schemas.burn_chart import LundBrowderRegion
from schemas.errors import InvalidInput
from schemas.ids import uuid7
from schemas.patient import Encounter, Patient
from schemas.records import Record, RecordKind
from schemas.wound import WoundSide, WoundState

Search = Annotated[str, QueryParameter(max_length=200, description="Part of a name or an identifier")]
PATIENT_SKIP = frozenset({"id", "merged_into"})
"""Filled by the page (the id) or only by a merge (merged_into), never typed."""
ENCOUNTER_SKIP = frozenset({"id", "patient_id"})


def matches(record: Record, query: str) -> bool:
    """Whether every word searched for is in the patient's names, record number or id (any case)."""
    data = record.data
    haystack = " ".join(
        str(v)
        for v in (data.get("given_name"), data.get("family_name"), data.get("medical_record_number"), record.meta.id)
        if v
    )
    return all(word in haystack.casefold() for word in query.casefold().split())


def _merged_into(services, who, patient: Record) -> Record | None:
    """The patient a merged duplicate's encounters and wounds moved to."""
    other = patient.data.get("merged_into")
    return services.records.get(who, RecordKind.patient, other) if other else None


class PatientPages(Controller):
    path = "/"
    include_in_schema = False

    @get("/", sync_to_thread=False)
    def start(self, request: AuthedRequest) -> Redirect:
        """Administrators do not read patients' records: their start page is the admin page."""
        return Redirect(path="/admin" if request.user.role == Role.admin else "/patients", status_code=303)

    @get("/patients", sync_to_thread=False)
    def list_(self, request: AuthedRequest, services: ServicesDep, q: Search = "") -> Template:
        patients = services.records.list_records(request.user, RecordKind.patient, limit=None)
        if q.strip():
            patients = [p for p in patients if matches(p, q)]
        patients.sort(key=lambda r: r.meta.updated_at, reverse=True)
        unread = services.transfers.unread_advice(request.user)
        names = {p.meta.id: patient_name(p.data) for p in patients}
        return page(
            request,
            "patients.html",
            patients=patients,
            q=q,
            name=patient_name,
            advice=[(a, names.get(a.patient_id, "a patient")) for a in unread],
            advice_by_patient=by_patient(unread),
        )

    @get("/patients/new", sync_to_thread=False)
    def new_form(self, request: AuthedRequest) -> Template:
        fields = form_fields(Patient, skip=PATIENT_SKIP)
        return page(request, "patient_new.html", fields=fields, record_id=uuid7(), errors={})

    @post("/patients/new", sync_to_thread=True, status_code=303)
    def create(self, request: AuthedRequest, data: FormBody, services: ServicesDep) -> Template | Redirect:
        record_id = posted_id(data)
        body, errors = parse_or_errors(Patient, data, {"id": record_id})
        if not errors:
            try:
                services.records.create(request.user, RecordKind.patient, record_id, body)
                return Redirect(path=f"/patients/{record_id}", status_code=303)
            except InvalidInput as exc:  # the service's own checks (a date of birth in the future)
                errors = service_errors(exc)
        fields = form_fields(Patient, raw=data, errors=errors, skip=PATIENT_SKIP)
        return page(request, "patient_new.html", 422, fields=fields, record_id=record_id, errors=errors)

    @get("/patients/{patient_id:str}", sync_to_thread=False)
    def read(self, patient_id: IdPath, request: AuthedRequest, services: ServicesDep) -> Template:
        who = request.user
        patient = services.records.get(who, RecordKind.patient, patient_id)
        encounters = services.records.list_records(who, RecordKind.encounter, parent_id=patient_id, limit=None)
        encounters.sort(key=lambda r: r.value().time_of_arrival, reverse=True)
        wounds = services.wounds.of_patient(who, patient_id)
        sections = [wound_section(s) for s in services.wounds.patient_healing(who, patient_id).wounds]
        return page(
            request,
            "patient.html",
            patient=patient,
            name=patient_name(patient.data),
            merged_into=_merged_into(services, who, patient),
            may_withdraw=RecordKind.patient in DELETE.get(who.role, frozenset()),
            problem=request.query_params.get("problem"),
            encounters=encounters,
            wounds=wounds,
            sections=sections,
            regions=list(LundBrowderRegion),
            sides=list(WoundSide),
            states=list(WoundState),
            record_id=uuid7(),
            errors={"": problem} if (problem := request.query_params.get("wound_problem")) else {},
        )

    @get("/patients/{patient_id:str}/encounters/new", sync_to_thread=False)
    def new_encounter_form(self, request: AuthedRequest, patient_id: IdPath, services: ServicesDep) -> Template:
        patient = services.records.get(request.user, RecordKind.patient, patient_id)
        clock = clinic_clock(request)
        # Arrival is now and the clinician is the one signed in; the mode is the clinician's choice, never preset.
        raw = {"time_of_arrival": clock.now_input(), "clinician": request.user.username}
        fields = form_fields(Encounter, raw=raw, skip=ENCOUNTER_SKIP, clock=clock)
        return page(
            request,
            "encounter_new.html",
            patient=patient,
            name=patient_name(patient.data),
            fields=fields,
            record_id=uuid7(),
            errors={},
        )

    @post("/patients/{patient_id:str}/encounters/new", sync_to_thread=True, status_code=303)
    def create_encounter(
        self, request: AuthedRequest, patient_id: IdPath, data: FormBody, services: ServicesDep
    ) -> Template | Redirect:
        patient = services.records.get(request.user, RecordKind.patient, patient_id)
        record_id = posted_id(data)
        clock = clinic_clock(request)
        body, errors = parse_or_errors(Encounter, data, {"id": record_id, "patient_id": patient_id}, clock.tz)
        if not errors:
            try:
                services.records.create(request.user, RecordKind.encounter, record_id, body)
                return Redirect(path=f"/encounters/{record_id}", status_code=303)
            except InvalidInput as exc:  # the service's own checks: a time in the future, injury after arrival
                errors = service_errors(exc)
        fields = form_fields(Encounter, raw=data, errors=errors, skip=ENCOUNTER_SKIP, clock=clock)
        return page(
            request,
            "encounter_new.html",
            422,
            patient=patient,
            name=patient_name(patient.data),
            fields=fields,
            record_id=record_id,
            errors=errors,
        )
