"""Patients and encounters: create, read, update with If-Match, withdraw, history."""

from __future__ import annotations

from typing import Annotated

from litestar import Controller, Response, delete, get, post, put
from litestar.openapi import ResponseSpec
from litestar.params import FromQuery, HeaderParameter, JSONBody, QueryParameter

from base.web.paths import IdPath
from base.web.problems import BODY, ONE, SESSION, problems
from base.web.site import AuthedRequest
from gateway.dependencies import ServicesDep
from gateway.records.http import outcome_response, parse_version, record_response
from schemas.patient import Encounter, Patient
from schemas.records import EncounterRecord, Record, RecordHistory, RecordKind

IfMatch = Annotated[str | None, HeaderParameter(name="If-Match", description='The version you edited, e.g. "3"')]
Reason = Annotated[str, QueryParameter(min_length=1, max_length=200, description="Why the record is withdrawn")]
MAX_INT64 = 2**63 - 1
Limit = Annotated[int, QueryParameter(ge=1, le=MAX_INT64, description="Page size (capped by the gateway)")]
Offset = Annotated[int, QueryParameter(ge=0, le=MAX_INT64)]

REPLAYED = {200: ResponseSpec(Record, description="Already stored with this content (a retry): the stored record")}
UPDATE = problems(*ONE, *BODY, 412, 422, 428)
WITHDRAW = problems(*ONE, 412, 422, 428)


class PatientController(Controller):
    path = "/api/v1/patients"
    tags = ["patients"]

    @post(
        "/",
        sync_to_thread=True,
        summary="Create a patient (the phone makes the id; retrying is safe)",
        responses={**REPLAYED, **problems(*BODY, *SESSION, 409, 422)},
    )
    def create(self, data: JSONBody[Patient], request: AuthedRequest, services: ServicesDep) -> Response[Record]:
        return outcome_response(services.records.create(request.user, RecordKind.patient, data.id, data))

    @get("/", sync_to_thread=False, summary="List patients", responses=problems(400, *SESSION))
    def list_(
        self,
        request: AuthedRequest,
        services: ServicesDep,
        include_deleted: FromQuery[bool] = False,
        limit: Limit = 100,
        offset: Offset = 0,
    ) -> list[Record]:
        return services.records.list_records(
            request.user, RecordKind.patient, include_deleted=include_deleted, limit=limit, offset=offset
        )

    @get("/{patient_id:str}", sync_to_thread=False, summary="Read a patient", responses=problems(*ONE))
    def read(self, patient_id: IdPath, request: AuthedRequest, services: ServicesDep) -> Response[Record]:
        return record_response(services.records.get(request.user, RecordKind.patient, patient_id))

    @put("/{patient_id:str}", sync_to_thread=True, summary="Update a patient (If-Match required)", responses=UPDATE)
    def update(
        self,
        patient_id: IdPath,
        data: JSONBody[Patient],
        request: AuthedRequest,
        services: ServicesDep,
        if_match: IfMatch = None,
    ) -> Response[Record]:
        version = parse_version(if_match, action="updating a patient")
        return outcome_response(services.records.update(request.user, RecordKind.patient, patient_id, data, version))

    @delete(
        "/{patient_id:str}",
        sync_to_thread=True,
        status_code=200,
        summary="Withdraw a patient (kept in history)",
        responses=WITHDRAW,
    )
    def withdraw(
        self,
        patient_id: IdPath,
        request: AuthedRequest,
        services: ServicesDep,
        reason: Reason,
        if_match: IfMatch = None,
    ) -> Response[Record]:
        version = parse_version(if_match, action="withdrawing a patient")
        return outcome_response(services.records.delete(request.user, RecordKind.patient, patient_id, version, reason))

    @get(
        "/{patient_id:str}/history",
        sync_to_thread=False,
        summary="Every version of a patient",
        responses=problems(*ONE),
    )
    def history(self, patient_id: IdPath, request: AuthedRequest, services: ServicesDep) -> RecordHistory:
        versions = services.records.history(request.user, RecordKind.patient, patient_id)
        return RecordHistory(kind=RecordKind.patient, id=patient_id, versions=versions)

    @get(
        "/{patient_id:str}/encounters", sync_to_thread=False, summary="A patient's encounters", responses=problems(*ONE)
    )
    def encounters(
        self,
        patient_id: IdPath,
        request: AuthedRequest,
        services: ServicesDep,
        include_deleted: FromQuery[bool] = False,
    ) -> list[Record]:
        services.records.get(request.user, RecordKind.patient, patient_id)
        return services.records.list_records(
            request.user, RecordKind.encounter, parent_id=patient_id, include_deleted=include_deleted, limit=None
        )


class EncounterController(Controller):
    path = "/api/v1/encounters"
    tags = ["encounters"]

    @post(
        "/",
        sync_to_thread=True,
        summary="Open an encounter for a patient",
        responses={**REPLAYED, **problems(*BODY, *SESSION, 404, 409, 422)},
    )
    def create(self, data: JSONBody[Encounter], request: AuthedRequest, services: ServicesDep) -> Response[Record]:
        return outcome_response(services.records.create(request.user, RecordKind.encounter, data.id, data))

    @get("/{encounter_id:str}", sync_to_thread=False, summary="Read an encounter", responses=problems(*ONE))
    def read(self, encounter_id: IdPath, request: AuthedRequest, services: ServicesDep) -> Response[Record]:
        return record_response(services.records.get(request.user, RecordKind.encounter, encounter_id))

    @put(
        "/{encounter_id:str}", sync_to_thread=True, summary="Update an encounter (If-Match required)", responses=UPDATE
    )
    def update(
        self,
        encounter_id: IdPath,
        data: JSONBody[Encounter],
        request: AuthedRequest,
        services: ServicesDep,
        if_match: IfMatch = None,
    ) -> Response[Record]:
        version = parse_version(if_match, action="updating an encounter")
        return outcome_response(
            services.records.update(request.user, RecordKind.encounter, encounter_id, data, version)
        )

    @delete(
        "/{encounter_id:str}", sync_to_thread=True, status_code=200, summary="Withdraw an encounter", responses=WITHDRAW
    )
    def withdraw(
        self,
        encounter_id: IdPath,
        request: AuthedRequest,
        services: ServicesDep,
        reason: Reason,
        if_match: IfMatch = None,
    ) -> Response[Record]:
        version = parse_version(if_match, action="withdrawing an encounter")
        return outcome_response(
            services.records.delete(request.user, RecordKind.encounter, encounter_id, version, reason)
        )

    @get(
        "/{encounter_id:str}/history",
        sync_to_thread=False,
        summary="Every version of an encounter",
        responses=problems(*ONE),
    )
    def history(self, encounter_id: IdPath, request: AuthedRequest, services: ServicesDep) -> RecordHistory:
        versions = services.records.history(request.user, RecordKind.encounter, encounter_id)
        return RecordHistory(kind=RecordKind.encounter, id=encounter_id, versions=versions)

    @get(
        "/{encounter_id:str}/record",
        sync_to_thread=False,
        summary="The encounter with every part and its assessment",
        responses=problems(*ONE),
    )
    def full_record(self, encounter_id: IdPath, request: AuthedRequest, services: ServicesDep) -> EncounterRecord:
        return services.records.encounter_record(request.user, encounter_id)
