"""3D burn analyses: request one for an encounter's pictures, follow it, cancel it, read and download results."""

from __future__ import annotations

from collections.abc import AsyncIterator

import anyio
import msgspec
from litestar import Controller, Response, get, post
from litestar.openapi import ResponseSpec
from litestar.params import FromPath, JSONBody
from litestar.response import File, ServerSentEvent, ServerSentEventMessage

from base.web.paths import IdPath
from base.web.problems import BODY, ONE, problems
from base.web.site import AuthedRequest
from gateway.dependencies import ServicesDep
from gateway.jobs.estimate import StageTimes, heading
from schemas.analysis import AnalysisResult
from schemas.base import utcnow
from schemas.jobs import FINISHED, AnalysisJob, AnalysisRequest, JobAttempt, JobEvent

EVENT_POLL_S = 0.5
KEEPALIVE_S = 15.0


def _event(job: AnalysisJob, times: StageTimes) -> JobEvent:
    said = heading(job, times, utcnow())
    return JobEvent(
        heading=said.text,
        step=said.step,
        steps=said.steps,
        remaining_s=said.remaining_s,
        id=job.id,
        state=job.state,
        stage=job.stage,
        fraction=job.fraction,
        message=job.message,
        error=job.error,
        result_status=job.result_status,
    )


class AnalysisController(Controller):
    path = "/api/v1"
    tags = ["analyses"]

    @post(
        "/encounters/{encounter_id:str}/analyses",
        sync_to_thread=True,
        status_code=202,
        summary="Queue a 3D burn analysis of the encounter's pictures (the same request again returns the same job)",
        responses={
            200: ResponseSpec(AnalysisJob, description="The same request was made before: its job"),
            **problems(*ONE, *BODY, 409, 422),
        },
    )
    def request_analysis(
        self, encounter_id: IdPath, data: JSONBody[AnalysisRequest], request: AuthedRequest, services: ServicesDep
    ) -> Response[AnalysisJob]:
        job, created = services.analyses.request(request.user, encounter_id, data)
        return Response(job, status_code=202 if created else 200, headers={"Location": f"/api/v1/analyses/{job.id}"})

    @get(
        "/encounters/{encounter_id:str}/analyses",
        sync_to_thread=False,
        summary="An encounter's analyses",
        responses=problems(*ONE),
    )
    def for_encounter(self, encounter_id: IdPath, request: AuthedRequest, services: ServicesDep) -> list[AnalysisJob]:
        return services.analyses.for_encounter(request.user, encounter_id)

    @get(
        "/analyses/{job_id:str}",
        sync_to_thread=False,
        summary="An analysis: state, stage, progress, queue place",
        responses=problems(*ONE),
    )
    def read(self, job_id: IdPath, request: AuthedRequest, services: ServicesDep) -> AnalysisJob:
        return services.analyses.get(request.user, job_id)

    @get(
        "/analyses/{job_id:str}/attempts",
        sync_to_thread=False,
        summary="Every try of an analysis: how it ended (exit code or signal, stage, reason) and its log's end",
        responses=problems(*ONE),
    )
    def attempts(self, job_id: IdPath, request: AuthedRequest, services: ServicesDep) -> list[JobAttempt]:
        return services.analyses.attempts(request.user, job_id)

    @post(
        "/analyses/{job_id:str}/cancel",
        sync_to_thread=True,
        status_code=200,
        summary="Cancel an analysis",
        responses=problems(*ONE, 409),
    )
    def cancel(self, job_id: IdPath, request: AuthedRequest, services: ServicesDep) -> AnalysisJob:
        return services.analyses.cancel(request.user, job_id)

    @get(
        "/analyses/{job_id:str}/result",
        sync_to_thread=False,
        summary="The measurement (area, perimeter, relief, volume, confidence, provenance) once finished",
        responses=problems(*ONE, 409),
    )
    def result(self, job_id: IdPath, request: AuthedRequest, services: ServicesDep) -> AnalysisResult:
        return services.analyses.result(request.user, job_id)

    @get(
        "/analyses/{job_id:str}/events",
        sync_to_thread=False,
        summary="Progress as server-sent events ('progress' on each change, 'end' when finished)",
        media_type="text/event-stream",
        responses=problems(*ONE),
    )
    def events(self, job_id: IdPath, request: AuthedRequest, services: ServicesDep) -> ServerSentEvent:
        first = services.analyses.get(request.user, job_id)  # 404/403 before the stream starts
        user = request.user
        times = services.analyses.stage_times(user)

        async def stream() -> AsyncIterator[ServerSentEventMessage]:
            job, last, quiet = first, None, 0.0
            while True:
                event = _event(job, times)
                if event != last:
                    finished = job.state in FINISHED
                    yield ServerSentEventMessage(
                        data=msgspec.json.encode(event).decode(), event="end" if finished else "progress"
                    )
                    if finished:
                        return
                    last, quiet = event, 0.0
                elif quiet >= KEEPALIVE_S:
                    yield ServerSentEventMessage(data=None, comment="waiting")
                    quiet = 0.0
                await anyio.sleep(EVENT_POLL_S)
                quiet += EVENT_POLL_S
                job = await anyio.to_thread.run_sync(services.analyses.get, user, job_id)

        return ServerSentEvent(stream(), headers={"Cache-Control": "no-cache", "X-Accel-Buffering": "no"})

    @get(
        "/analyses/{job_id:str}/artifacts",
        sync_to_thread=True,
        summary="The files an analysis made: painted mesh (GLB), surface mesh, masks, overlays, result JSON",
        responses=problems(*ONE),
    )
    def artifacts(self, job_id: IdPath, request: AuthedRequest, services: ServicesDep) -> list[str]:
        return services.analyses.artifacts(request.user, job_id)

    @get(
        "/analyses/{job_id:str}/artifacts/{name:path}",
        sync_to_thread=True,
        summary="Download one of those files",
        responses=problems(*ONE),
    )
    def artifact(self, job_id: IdPath, name: FromPath[str], request: AuthedRequest, services: ServicesDep) -> File:
        path = services.analyses.artifact(request.user, job_id, name.lstrip("/"))
        return File(path=path, filename=path.name)
