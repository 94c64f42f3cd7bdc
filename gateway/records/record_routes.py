"""The routes every versioned record of its own kind answers (patients, encounters, wounds): read, update with
If-Match, withdraw with a reason, and history, made once for a kind and put into its controller.

No `from __future__ import annotations`: the handlers' annotations name the kind's Struct, a local of the factory,
and Litestar reads them at start-up."""

from collections.abc import Callable
from typing import Annotated

from litestar import Response, delete, get, put
from litestar.openapi import ResponseSpec
from litestar.params import HeaderParameter, JSONBody, QueryParameter

from base.web.paths import IdPath
from base.web.problems import BODY, ONE, problems
from base.web.site import AuthedRequest
from gateway.dependencies import ServicesDep
from gateway.records.http import outcome_response, parse_version, record_response
from schemas.records import Record, RecordHistory, RecordKind

IfMatch = Annotated[str | None, HeaderParameter(name="If-Match", description='The version you edited, e.g. "3"')]
Reason = Annotated[str, QueryParameter(min_length=1, max_length=200, description="Why the record is withdrawn")]

REPLAYED = {200: ResponseSpec(Record, description="Already stored with this content (a retry): the stored record")}
UPDATE = problems(*ONE, *BODY, 412, 422, 428)
WITHDRAW = problems(*ONE, 412, 422, 428)


def record_routes(kind: RecordKind, struct: type, a_record: str) -> dict[str, Callable]:
    """read, update, withdraw and history of the kind at /{record_id}; `a_record` names one in the summaries and
    messages ("a patient", "an encounter")."""

    @get("/{record_id:str}", sync_to_thread=False, summary=f"Read {a_record}", responses=problems(*ONE))
    def read(self, record_id: IdPath, request: AuthedRequest, services: ServicesDep) -> Response[Record]:
        return record_response(services.records.get(request.user, kind, record_id))

    @put("/{record_id:str}", sync_to_thread=True, summary=f"Update {a_record} (If-Match required)", responses=UPDATE)
    def update(
        self,
        record_id: IdPath,
        data: JSONBody[struct],
        request: AuthedRequest,
        services: ServicesDep,
        if_match: IfMatch = None,
    ) -> Response[Record]:
        version = parse_version(if_match, action=f"updating {a_record}")
        return outcome_response(services.records.update(request.user, kind, record_id, data, version))

    @delete(
        "/{record_id:str}",
        sync_to_thread=True,
        status_code=200,
        summary=f"Withdraw {a_record} (kept in history)",
        responses=WITHDRAW,
    )
    def withdraw(
        self,
        record_id: IdPath,
        request: AuthedRequest,
        services: ServicesDep,
        reason: Reason,
        if_match: IfMatch = None,
    ) -> Response[Record]:
        version = parse_version(if_match, action=f"withdrawing {a_record}")
        return outcome_response(services.records.delete(request.user, kind, record_id, version, reason))

    @get(
        "/{record_id:str}/history",
        sync_to_thread=False,
        summary=f"Every version of {a_record}",
        responses=problems(*ONE),
    )
    def history(self, record_id: IdPath, request: AuthedRequest, services: ServicesDep) -> RecordHistory:
        versions = services.records.history(request.user, kind, record_id)
        return RecordHistory(kind=kind, id=record_id, versions=versions)

    return {"read": read, "update": update, "withdraw": withdraw, "history": history}


def with_record_routes(controller: type, kind: RecordKind, struct: type, a_record: str) -> type:
    """The controller with the kind's read, update, withdraw and history routes added."""
    for name, handler in record_routes(kind, struct, a_record).items():
        setattr(controller, name, handler)
    return controller
