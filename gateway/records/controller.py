"""Patients and encounters: create and list here; read, update with If-Match, withdraw and history from
gateway/records/record_routes.py, as every versioned record of its own kind answers them."""

from __future__ import annotations

from typing import Annotated

from litestar import Controller, Response, get, post
from litestar.params import FromQuery, JSONBody, QueryParameter

from base.web.paths import IdPath
from base.web.problems import BODY, ONE, SESSION, problems
from base.web.site import AuthedRequest
from gateway.dependencies import ServicesDep
from gateway.records.http import outcome_response
from gateway.records.merge import MergeOutcome, merge_patients
from gateway.records.record_routes import REPLAYED, with_record_routes
from schemas.patient import Encounter, Patient, PatientMerge
from schemas.records import EncounterRecord, Record, RecordKind

MAX_INT64 = 2**63 - 1
Limit = Annotated[int, QueryParameter(ge=1, le=MAX_INT64, description="Page size (capped by the gateway)")]
Offset = Annotated[int, QueryParameter(ge=0, le=MAX_INT64)]


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

    @post(
        "/{patient_id:str}/merge",
        sync_to_thread=True,
        status_code=200,
        summary="Merge another record of the same person into this patient (its encounters and wounds move here)",
        responses=problems(*ONE, *BODY, 409, 412, 422),
    )
    def merge(
        self, patient_id: IdPath, data: JSONBody[PatientMerge], request: AuthedRequest, services: ServicesDep
    ) -> MergeOutcome:
        return merge_patients(services.db, services.config, request.user, patient_id, data.duplicate_id, data.reason)


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

    @get(
        "/{encounter_id:str}/record",
        sync_to_thread=False,
        summary="The encounter with every part and its assessment",
        responses=problems(*ONE),
    )
    def full_record(self, encounter_id: IdPath, request: AuthedRequest, services: ServicesDep) -> EncounterRecord:
        return services.records.encounter_record(request.user, encounter_id)


with_record_routes(PatientController, RecordKind.patient, Patient, "a patient")
with_record_routes(EncounterController, RecordKind.encounter, Encounter, "an encounter")
