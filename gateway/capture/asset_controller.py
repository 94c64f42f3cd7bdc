"""Stored photos, videos and frames: their records, quality verdicts and original bytes."""

from __future__ import annotations

from litestar import Controller, delete, get, post, put
from litestar.params import JSONBody
from litestar.response import File

from base.web.paths import IdPath
from base.web.problems import BODY, ONE, SESSION, problems
from base.web.site import AuthedRequest
from gateway.dependencies import ServicesDep
from schemas.capture import Asset, CaptureReadiness, SetAsideBody
from schemas.wound import AssetWound


class AssetController(Controller):
    path = "/api/v1"
    tags = ["assets"]

    @get(
        "/assets/{asset_id:str}",
        sync_to_thread=False,
        summary="A stored photo, video or frame, with its verdict",
        responses=problems(*ONE),
    )
    def read(self, asset_id: IdPath, request: AuthedRequest, services: ServicesDep) -> Asset:
        return services.assets.get(request.user, asset_id)

    @put(
        "/assets/{asset_id:str}/wound",
        sync_to_thread=True,
        summary="Say which wound a picture shows (a video's frames follow it); null for none in particular",
        responses=problems(*BODY, *SESSION, 404, 422),
    )
    def set_wound(
        self, asset_id: IdPath, data: JSONBody[AssetWound], request: AuthedRequest, services: ServicesDep
    ) -> Asset:
        return services.assets.set_wound(request.user, asset_id, data.wound_id)

    @post(
        "/assets/{asset_id:str}/set-aside",
        sync_to_thread=True,
        status_code=200,
        summary="Set a picture aside with a reason: it no longer counts for readiness, analyses or the case sent",
        responses=problems(*BODY, *SESSION, 404, 422),
    )
    def set_aside(
        self, asset_id: IdPath, data: JSONBody[SetAsideBody], request: AuthedRequest, services: ServicesDep
    ) -> Asset:
        return services.assets.set_aside(request.user, asset_id, data.reason)

    @delete(
        "/assets/{asset_id:str}/set-aside",
        sync_to_thread=True,
        status_code=200,
        summary="Put a picture set aside back: it counts again",
        responses=problems(*ONE, 422),
    )
    def put_back(self, asset_id: IdPath, request: AuthedRequest, services: ServicesDep) -> Asset:
        return services.assets.set_aside(request.user, asset_id, None)

    @get(
        "/assets/{asset_id:str}/file",
        sync_to_thread=True,
        summary="The original bytes, exactly as uploaded",
        responses=problems(*ONE),
    )
    def download(self, asset_id: IdPath, request: AuthedRequest, services: ServicesDep) -> File:
        asset, path = services.assets.file(request.user, asset_id)
        return File(
            path=path, filename=asset.filename, media_type=asset.media_type.value, headers={"ETag": f'"{asset.sha256}"'}
        )

    @get(
        "/encounters/{encounter_id:str}/assets",
        sync_to_thread=False,
        summary="An encounter's photos, videos and frames",
        responses=problems(*ONE),
    )
    def for_encounter(self, encounter_id: IdPath, request: AuthedRequest, services: ServicesDep) -> list[Asset]:
        return services.assets.for_encounter(request.user, encounter_id)

    # 422: the encounter was withdrawn (no pictures can be added to it, nor analysed).
    @get(
        "/encounters/{encounter_id:str}/capture-readiness",
        sync_to_thread=True,
        summary="Is the capture set ready for 3D analysis, and what is missing",
        responses=problems(*ONE, 422),
    )
    def readiness(self, encounter_id: IdPath, request: AuthedRequest, services: ServicesDep) -> CaptureReadiness:
        return services.assets.readiness(request.user, encounter_id)
