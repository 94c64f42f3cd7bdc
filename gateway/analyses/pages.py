"""The 3D analysis pages: request one (optionally with burn outlines drawn on a photo and ruler points clicked on
photos), follow its progress live over the API's server-sent events, and read the result: the painted burn
surface in a 3D viewer, the overlays, and every figure with its unit, scale source and confidence."""

from __future__ import annotations

import re
from typing import Any

import msgspec
from litestar import Controller, get, post
from litestar.response import Redirect, Template

from base.web.pages.forms import FormBody, posted_text
from base.web.pages.rendering import page
from base.web.paths import IdPath
from base.web.site import AuthedRequest
from gateway.analyses.summary import summary
from gateway.capture.picture_pages import grouped
from gateway.dependencies import ServicesDep
from gateway.jobs.estimate import heading
from gateway.pages.encounter_view import encounter_header
from gateway.pages.healing_view import PAINTED_SURFACE
from schemas.base import utcnow
from schemas.errors import BurnedgeError, InvalidInput
from schemas.jobs import FINISHED, AnalysisRequest

_POINT = re.compile(r"\s*(-?\d+(?:\.\d+)?)\s*,\s*(-?\d+(?:\.\d+)?)\s*")


def _points(text: str, what: str) -> list[list[float]]:
    """'x,y; x,y; ...' (pixels of the full photo) as [[x, y], ...]."""
    points = []
    for piece in filter(str.strip, text.split(";")):
        match = _POINT.fullmatch(piece)
        if match is None:
            raise InvalidInput(f"{what}: {piece.strip()!r} is not a point 'x, y' in pixels")
        points.append([float(match[1]), float(match[2])])
    return points


def analysis_request(data: dict[str, Any]) -> AnalysisRequest:
    """The AnalysisRequest the form describes; its own validation names what is wrong."""
    body: dict[str, Any] = {}
    if wound := posted_text(data, "wound_id").strip():
        body["wound_id"] = wound
    marker = posted_text(data, "marker_side_mm").strip()
    if marker:
        body["marker_side_mm"] = marker
    masks, marks = [], []
    for name, value in data.items():
        text = value if isinstance(value, str) else ""
        if name.startswith("outline.") and text.strip():
            masks.append({"asset_id": name[8:], "polygons": [_points(text, "outline")]})
        elif name.startswith("ruler.") and text.strip():
            a_b = _points(text, "ruler")
            if len(a_b) != 2:
                raise InvalidInput("ruler: click exactly two points (the ruler's two marks) on each photo you use")
            marks.append({"asset_id": name[6:], "a": a_b[0], "b": a_b[1]})
    if masks:
        body["masks"] = masks
    distance = posted_text(data, "ruler_distance_mm").strip()
    if marks or distance:
        body["ruler"] = {"distance_mm": distance or 0, "marks": marks}
    try:
        return msgspec.convert(body, AnalysisRequest, strict=False)
    except msgspec.ValidationError as exc:
        raise InvalidInput(f"the analysis request is not valid: {exc}") from exc


class AnalysisPages(Controller):
    path = "/"
    include_in_schema = False

    @get("/encounters/{encounter_id:str}/analyses", sync_to_thread=False)
    def analyses(self, encounter_id: IdPath, request: AuthedRequest, services: ServicesDep) -> Template:
        return self._list(request, services, encounter_id, None, 200)

    def _list(self, request, services, encounter_id, problem, status):
        encounter, patient = encounter_header(services, request.user, encounter_id)
        jobs = services.analyses.for_encounter(request.user, encounter_id)
        photos, videos = grouped(services.assets.for_encounter(request.user, encounter_id))
        usable = [a for a in photos if a.verdict and a.verdict.accepted]
        wounds = services.wounds.of_patient(request.user, patient.meta.id)
        return page(
            request,
            "analyses.html",
            status,
            encounter=encounter,
            patient=patient,
            tab="analyses",
            jobs=jobs,
            photos=usable,
            problem=problem,
            wounds=wounds,
            wound_labels={w.meta.id: w.value().label for w in wounds},
        )

    @post("/encounters/{encounter_id:str}/analyses", sync_to_thread=True, status_code=303)
    def request_analysis(
        self, encounter_id: IdPath, request: AuthedRequest, data: FormBody, services: ServicesDep
    ) -> Template | Redirect:
        try:
            job, _ = services.analyses.request(request.user, encounter_id, analysis_request(data))
        except InvalidInput as exc:
            return self._list(request, services, encounter_id, exc.detail, 422)
        return Redirect(path=f"/analyses/{job.id}", status_code=303)

    @get("/analyses/{job_id:str}", sync_to_thread=True)
    def analysis(self, job_id: IdPath, request: AuthedRequest, services: ServicesDep) -> Template:
        job = services.analyses.get(request.user, job_id)
        encounter, patient = encounter_header(services, request.user, job.encounter_id)
        result, problem, artifacts, lead = None, None, [], None
        progress = heading(job, services.analyses.stage_times(request.user), utcnow())
        if job.state in FINISHED:
            try:
                result = services.analyses.result(request.user, job_id)
                artifacts = services.analyses.artifacts(request.user, job_id)
                track = services.wounds.healing(request.user, job.wound_id).track if job.wound_id else None
                lead = summary(result, track, job_id)
            except BurnedgeError as exc:
                problem = exc.detail
        base = f"/api/v1/analyses/{job_id}/artifacts/"
        return page(
            request,
            "analysis.html",
            encounter=encounter,
            patient=patient,
            tab="analyses",
            job=job,
            progress=progress,
            finished=job.state in FINISHED,
            result=result,
            lead=lead,
            problem=problem,
            surface=base + PAINTED_SURFACE if PAINTED_SURFACE in artifacts else None,
            overlays=[base + name for name in artifacts if name.startswith("segmentation/overlays/")],
        )
