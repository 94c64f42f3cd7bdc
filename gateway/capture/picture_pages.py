"""The pictures page: every photo, video and extracted frame of an encounter with its quality verdict and
guidance, the readiness for 3D, and uploading from the browser (a plain form; with scripts, the vendored tus
client, so a large video resumes after the Wi-Fi drops)."""

from __future__ import annotations

from functools import partial
from typing import Annotated, Any

import anyio
from litestar import Controller, get, post
from litestar.datastructures import UploadFile
from litestar.enums import RequestEncodingType
from litestar.params import Body
from litestar.response import File, Redirect, Template

from base.web.pages.forms import FormBody, posted_text
from base.web.pages.rendering import page
from base.web.paths import IdPath
from base.web.site import AuthedRequest
from gateway.capture.uploads import check_filename
from gateway.dependencies import ServicesDep
from gateway.pages.encounter_view import encounter_header
from gateway.scheduler import run_frames_now
from schemas.capture import Asset, AssetKind
from schemas.errors import BurnedgeError, InvalidInput
from schemas.ids import uuid7

UploadForm = Annotated[dict[str, Any], Body(media_type=RequestEncodingType.MULTI_PART)]
"""Files and the wound picked: Any, as msgspec cannot convert a union of UploadFile and str."""
COPY_CHUNK = 1 << 20


def grouped(assets: list[Asset]) -> tuple[list[Asset], list[tuple[Asset, list[Asset]]]]:
    """(photos, [(video, its frames)]) in the order they arrived."""
    frames: dict[str, list[Asset]] = {}
    for asset in assets:
        if asset.kind == AssetKind.frame and asset.source_asset_id:
            frames.setdefault(asset.source_asset_id, []).append(asset)
    photos = [a for a in assets if a.kind == AssetKind.photo]
    videos = [(a, frames.get(a.id, [])) for a in assets if a.kind == AssetKind.video]
    return photos, videos


class PicturePages(Controller):
    path = "/"
    include_in_schema = False

    @get("/encounters/{encounter_id:str}/pictures", sync_to_thread=True)
    def pictures(self, encounter_id: IdPath, request: AuthedRequest, services: ServicesDep) -> Template:
        encounter, patient = encounter_header(services, request.user, encounter_id)
        assets = services.assets.for_encounter(request.user, encounter_id)
        photos, videos = grouped(assets)
        try:
            readiness, readiness_problem = services.assets.readiness(request.user, encounter_id), None
        except BurnedgeError as exc:
            readiness, readiness_problem = None, exc.detail
        wounds = services.wounds.of_patient(request.user, patient.meta.id)
        stored = request.query_params.getall("stored", [])
        refused = request.query_params.getall("refused", [])
        return page(
            request,
            "pictures.html",
            encounter=encounter,
            patient=patient,
            tab="pictures",
            photos=photos,
            videos=videos,
            readiness=readiness,
            readiness_problem=readiness_problem,
            stored=stored,
            refused=refused,
            wounds=wounds,
            wound_labels={w.meta.id: w.value().label for w in wounds},
        )

    @post("/encounters/{encounter_id:str}/pictures", status_code=303)
    async def upload(
        self, encounter_id: IdPath, request: AuthedRequest, data: UploadForm, services: ServicesDep
    ) -> Redirect:
        """The form without scripts: each chosen file is checked and stored like a tus upload's."""
        files = data.get("files", [])
        files = [files] if isinstance(files, UploadFile) else [f for f in files if isinstance(f, UploadFile)]
        files = [f for f in files if f.filename]
        if not files:  # the page again, saying so, rather than an error page
            refused = ["nothing was uploaded: choose at least one photo or video"]
            return Redirect(
                path=f"/encounters/{encounter_id}/pictures", query_params={"refused": refused}, status_code=303
            )
        wound = data.get("wound_id")
        wound_id = wound if isinstance(wound, str) and wound else None
        stored, refused = [], []
        for upload in files:
            part = services.assets.store.part(f"form-{uuid7()}")
            try:
                with open(part, "wb") as out:
                    while chunk := await upload.read(COPY_CHUNK):
                        out.write(chunk)
                name = check_filename(upload.filename)
                store = partial(services.assets.store_upload, request.user, encounter_id, part, name, wound_id=wound_id)
                asset = await anyio.to_thread.run_sync(store)
                stored.append(asset.filename)
                if asset.media_type.is_video:
                    run_frames_now(request.app.state.scheduler)
            except InvalidInput as exc:
                refused.append(f"{upload.filename}: {exc.detail}")
            finally:
                part.unlink(missing_ok=True)
                await upload.close()
        return Redirect(
            path=f"/encounters/{encounter_id}/pictures",
            query_params={"stored": stored, "refused": refused},
            status_code=303,
        )

    @post("/pictures/{asset_id:str}/set-aside", sync_to_thread=True, status_code=303)
    def set_aside(self, asset_id: IdPath, request: AuthedRequest, data: FormBody, services: ServicesDep) -> Redirect:
        asset = services.assets.set_aside(request.user, asset_id, posted_text(data, "reason"))
        return Redirect(path=f"/encounters/{asset.encounter_id}/pictures#photos-aside", status_code=303)

    @post("/pictures/{asset_id:str}/put-back", sync_to_thread=True, status_code=303)
    def put_back(self, asset_id: IdPath, request: AuthedRequest, services: ServicesDep) -> Redirect:
        asset = services.assets.set_aside(request.user, asset_id, None)
        return Redirect(path=f"/encounters/{asset.encounter_id}/pictures", status_code=303)

    @get("/pictures/{asset_id:str}/thumbnail", sync_to_thread=True)
    def thumbnail(self, asset_id: IdPath, request: AuthedRequest, services: ServicesDep) -> File:
        path = services.thumbnails.thumbnail(request.user, asset_id)
        return File(
            path=path,
            media_type="image/jpeg",
            content_disposition_type="inline",
            headers={"Cache-Control": "private, max-age=86400"},
        )
