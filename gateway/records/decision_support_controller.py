"""Decision support of an encounter: read it, recompute it as of now, and record a clinician's act on it."""

from __future__ import annotations

from litestar import Controller, Response, get, post

from base.web.paths import IdPath
from base.web.problems import BODY, ONE, problems
from base.web.site import AuthedRequest
from gateway.dependencies import ServicesDep
from gateway.records.http import parse_version, record_response
from gateway.records.record_routes import IfMatch
from schemas.decision_support import RecommendationAct
from schemas.records import Record, RecordHistory, RecordKind


class DecisionSupportController(Controller):
    path = "/api/v1/encounters/{encounter_id:str}/decision-support"
    tags = ["encounter record"]

    @get(
        "/",
        sync_to_thread=False,
        summary="The recommendations, each pending, accepted or declined",
        responses=problems(*ONE),
    )
    def read(self, encounter_id: IdPath, request: AuthedRequest, services: ServicesDep) -> Response[Record]:
        return record_response(services.decision_support.get(request.user, encounter_id))

    @get("/history", sync_to_thread=False, summary="Every version of the recommendations", responses=problems(*ONE))
    def history(self, encounter_id: IdPath, request: AuthedRequest, services: ServicesDep) -> RecordHistory:
        kind = RecordKind.decision_support
        return RecordHistory(
            kind=kind, id=encounter_id, versions=services.records.history(request.user, kind, encounter_id)
        )

    @post(
        "/",
        sync_to_thread=True,
        status_code=200,
        summary="Recompute the recommendations as of now (the cooling window and days since injury move)",
        responses=problems(*ONE, 409),
    )
    def recompute(self, encounter_id: IdPath, request: AuthedRequest, services: ServicesDep) -> Response[Record]:
        return record_response(services.decision_support.recompute(request.user, encounter_id))

    @post(
        "/acts",
        sync_to_thread=True,
        status_code=200,
        summary="Accept a recommendation, or decline it with a reason (If-Match: the version you read)",
        responses=problems(*ONE, *BODY, 409, 412, 422, 428),
    )
    def act(
        self,
        encounter_id: IdPath,
        data: RecommendationAct,
        request: AuthedRequest,
        services: ServicesDep,
        if_match: IfMatch = None,
    ) -> Response[Record]:
        version = parse_version(if_match, action="accepting or declining a recommendation")
        return record_response(services.decision_support.act(request.user, encounter_id, data, version))
