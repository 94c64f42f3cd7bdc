"""A patient's wounds over HTTP: created and listed under the patient, then read, changed and withdrawn by id."""

from __future__ import annotations

from litestar import Controller, Response, delete, get, post, put
from litestar.params import FromQuery, JSONBody

from base.web.paths import IdPath
from base.web.problems import BODY, ONE, SESSION, problems
from base.web.site import AuthedRequest
from gateway.dependencies import ServicesDep
from gateway.records.controller import REPLAYED, UPDATE, WITHDRAW, IfMatch, Reason
from gateway.records.http import outcome_response, parse_version, record_response
from schemas.records import Record, RecordHistory, RecordKind
from schemas.wound import Wound
from schemas.wound_healing import PatientHealing, WoundHealing


class PatientWoundsController(Controller):
    path = "/api/v1/patients/{patient_id:str}/wounds"
    tags = ["wounds"]

    @post(
        "/",
        sync_to_thread=True,
        summary="Record a wound of the patient (the phone makes the id; retrying is safe)",
        responses={**REPLAYED, **problems(*BODY, *SESSION, 404, 409, 422)},
    )
    def create(
        self, patient_id: IdPath, data: JSONBody[Wound], request: AuthedRequest, services: ServicesDep
    ) -> Response[Record]:
        return outcome_response(services.wounds.create(request.user, patient_id, data))

    @get("/", sync_to_thread=False, summary="A patient's wounds, oldest first", responses=problems(*ONE))
    def list_(
        self,
        patient_id: IdPath,
        request: AuthedRequest,
        services: ServicesDep,
        include_deleted: FromQuery[bool] = False,
    ) -> list[Record]:
        return services.wounds.of_patient(request.user, patient_id, include_deleted=include_deleted)


class PatientHealingController(Controller):
    path = "/api/v1/patients/{patient_id:str}/healing"
    tags = ["wounds"]

    @get(
        "/",
        sync_to_thread=True,
        summary="Healing over time, one section per wound: its visits aligned, area change, rate, share of the body",
        responses=problems(*ONE),
    )
    def read(self, patient_id: IdPath, request: AuthedRequest, services: ServicesDep) -> PatientHealing:
        return services.wounds.patient_healing(request.user, patient_id)


class WoundController(Controller):
    path = "/api/v1/wounds"
    tags = ["wounds"]

    @get("/{wound_id:str}", sync_to_thread=False, summary="Read a wound", responses=problems(*ONE))
    def read(self, wound_id: IdPath, request: AuthedRequest, services: ServicesDep) -> Response[Record]:
        return record_response(services.wounds.get(request.user, wound_id))

    @put("/{wound_id:str}", sync_to_thread=True, summary="Update a wound (If-Match required)", responses=UPDATE)
    def update(
        self,
        wound_id: IdPath,
        data: JSONBody[Wound],
        request: AuthedRequest,
        services: ServicesDep,
        if_match: IfMatch = None,
    ) -> Response[Record]:
        version = parse_version(if_match, action="updating a wound")
        return outcome_response(services.wounds.update(request.user, wound_id, data, version))

    @delete(
        "/{wound_id:str}",
        sync_to_thread=True,
        status_code=200,
        summary="Withdraw a wound (kept in history)",
        responses=WITHDRAW,
    )
    def withdraw(
        self,
        wound_id: IdPath,
        request: AuthedRequest,
        services: ServicesDep,
        reason: Reason,
        if_match: IfMatch = None,
    ) -> Response[Record]:
        version = parse_version(if_match, action="withdrawing a wound")
        return outcome_response(services.wounds.withdraw(request.user, wound_id, version, reason))

    @get(
        "/{wound_id:str}/healing",
        sync_to_thread=True,
        summary="The wound's healing track (its own analyses only) and its measured share of the body",
        responses=problems(*ONE),
    )
    def healing(self, wound_id: IdPath, request: AuthedRequest, services: ServicesDep) -> WoundHealing:
        return services.wounds.healing(request.user, wound_id)

    @get("/{wound_id:str}/history", sync_to_thread=False, summary="Every version of a wound", responses=problems(*ONE))
    def history(self, wound_id: IdPath, request: AuthedRequest, services: ServicesDep) -> RecordHistory:
        versions = services.wounds.history(request.user, wound_id)
        return RecordHistory(kind=RecordKind.wound, id=wound_id, versions=versions)
