"""A patient's wounds over HTTP: created and listed under the patient, their healing; read, update with If-Match,
withdraw and history from gateway/records/record_routes.py, as for patients and encounters."""

from __future__ import annotations

from litestar import Controller, Response, get, post
from litestar.params import FromQuery, JSONBody

from base.web.paths import IdPath
from base.web.problems import BODY, ONE, SESSION, problems
from base.web.site import AuthedRequest
from gateway.dependencies import ServicesDep
from gateway.records.http import outcome_response
from gateway.records.record_routes import REPLAYED, with_record_routes
from schemas.records import Record, RecordKind
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

    @get(
        "/{record_id:str}/healing",
        sync_to_thread=True,
        summary="The wound's healing track (its own analyses only) and its measured share of the body",
        responses=problems(*ONE),
    )
    def healing(self, record_id: IdPath, request: AuthedRequest, services: ServicesDep) -> WoundHealing:
        return services.wounds.healing(request.user, record_id)


with_record_routes(WoundController, RecordKind.wound, Wound, "a wound")
