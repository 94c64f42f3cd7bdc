"""The parts of an encounter's record, one controller per part, all built the same way.

PUT creates a part with If-None-Match: * and updates it with If-Match: <version>.
This module deliberately has no `from __future__ import annotations`: the handlers'
body type is a variable, and Litestar must see the real class.
"""

from typing import Annotated

from litestar import Controller, Response, delete, get, post, put
from litestar.openapi import ResponseSpec
from litestar.params import HeaderParameter, JSONBody

from base.web.paths import IdPath
from base.web.problems import ONE, problems
from base.web.site import AuthedRequest
from gateway.dependencies import ServicesDep
from gateway.records.http import outcome_response, parse_version, record_response
from gateway.records.record_routes import UPDATE, WITHDRAW, IfMatch, Reason
from schemas.burn_chart import BurnChart
from schemas.errors import Conflict, InvalidInput, VersionMismatch
from schemas.record_parts import Intake, Mechanism, PrimarySurvey, Resuscitation, SecondarySurvey
from schemas.records import Record, RecordHistory, RecordKind

IfNoneMatch = Annotated[
    str | None, HeaderParameter(name="If-None-Match", description="* to create the part only if it does not exist yet")
]

WRITABLE_PARTS = {
    "intake": (RecordKind.intake, Intake),
    "primary-survey": (RecordKind.primary_survey, PrimarySurvey),
    "secondary-survey": (RecordKind.secondary_survey, SecondarySurvey),
    "mechanism": (RecordKind.mechanism, Mechanism),
    "burn-chart": (RecordKind.burn_chart, BurnChart),
    "resuscitation": (RecordKind.resuscitation, Resuscitation),
}


def _readers(kind: RecordKind, label: str):
    @get("/", sync_to_thread=False, summary=f"Read the {label}", responses=problems(*ONE))
    def read(self, encounter_id: IdPath, request: AuthedRequest, services: ServicesDep) -> Response[Record]:
        return record_response(services.records.get(request.user, kind, encounter_id))

    @get("/history", sync_to_thread=False, summary=f"Every version of the {label}", responses=problems(*ONE))
    def history(self, encounter_id: IdPath, request: AuthedRequest, services: ServicesDep) -> RecordHistory:
        return RecordHistory(
            kind=kind, id=encounter_id, versions=services.records.history(request.user, kind, encounter_id)
        )

    return read, history


def writable_part_controller(slug: str, kind: RecordKind, struct: type) -> type[Controller]:
    label = kind.label
    read, history = _readers(kind, label)

    @put(
        "/",
        sync_to_thread=True,
        summary=f"Create (If-None-Match: *) or update (If-Match) the {label}",
        responses={**UPDATE, 201: ResponseSpec(Record, description=f"The {label} was created")},
    )
    def write(
        self,
        encounter_id: IdPath,
        data: JSONBody[struct],
        request: AuthedRequest,
        services: ServicesDep,
        if_match: IfMatch = None,
        if_none_match: IfNoneMatch = None,
    ) -> Response[Record]:
        if if_match is None and if_none_match is not None:
            if if_none_match.strip() != "*":
                raise InvalidInput('If-None-Match must be "*" (create only if absent)')
            try:
                return outcome_response(services.records.create(request.user, kind, encounter_id, data))
            except Conflict as exc:
                # RFC 9110: If-None-Match: * fails with 412 when the part already exists.
                raise VersionMismatch(exc.detail, current=exc.current) from exc
        version = parse_version(if_match, action=f"updating the {label} (or If-None-Match: * to create it)")
        return outcome_response(services.records.update(request.user, kind, encounter_id, data, version))

    @delete("/", sync_to_thread=True, status_code=200, summary=f"Withdraw the {label}", responses=WITHDRAW)
    def withdraw(
        self,
        encounter_id: IdPath,
        request: AuthedRequest,
        services: ServicesDep,
        reason: Reason,
        if_match: IfMatch = None,
    ) -> Response[Record]:
        version = parse_version(if_match, action=f"withdrawing the {label}")
        return outcome_response(services.records.delete(request.user, kind, encounter_id, version, reason))

    attrs = {
        "path": f"/api/v1/encounters/{{encounter_id:str}}/{slug}",
        "tags": ["encounter record"],
        "read": read,
        "history": history,
        "write": write,
        "withdraw": withdraw,
    }
    return type(f"{struct.__name__}Controller", (Controller,), attrs)


def assessment_controller() -> type[Controller]:
    read, history = _readers(RecordKind.assessment, "calculator results (%TBSA, fluids, referral)")

    @post(
        "/",
        sync_to_thread=True,
        status_code=200,
        summary="Recompute %TBSA, fluids and referral as of now (e.g. after more fluid was given)",
        responses=problems(*ONE, 409),
    )
    def recompute(self, encounter_id: IdPath, request: AuthedRequest, services: ServicesDep) -> Response[Record]:
        return record_response(services.records.recompute_assessment(request.user, encounter_id))

    attrs = {
        "path": "/api/v1/encounters/{encounter_id:str}/assessment",
        "tags": ["encounter record"],
        "read": read,
        "history": history,
        "recompute": recompute,
    }
    return type("AssessmentController", (Controller,), attrs)


PART_CONTROLLERS = [writable_part_controller(slug, kind, struct) for slug, (kind, struct) in WRITABLE_PARTS.items()]
PART_CONTROLLERS.append(assessment_controller())
