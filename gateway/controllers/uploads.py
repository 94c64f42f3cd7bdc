"""Resumable uploads over the tus 1.0 protocol (core, creation, termination, checksum, expiration).

Existing mobile tus clients work unchanged: send the session token as a header, the
encounter in Upload-Metadata (`encounter_id`, plus `filename`), and the bytes in PATCHes.
The last PATCH's answer carries the stored asset and its quality verdict in headers
(Burnedge-Asset-Id, Burnedge-Accepted, Burnedge-Reasons); GET on the upload gives it all.
"""

from __future__ import annotations

import base64
import binascii
import hashlib
import os
from email.utils import format_datetime
from typing import Annotated

import anyio
from litestar import Controller, Request, Response, delete, get, head, post, route
from litestar.enums import HttpMethod
from litestar.exceptions import InternalServerException
from litestar.params import FromPath, HeaderParameter

from gateway.dependencies import AuthedRequest, ServicesDep
from gateway.scheduler import run_frames_now
from gateway.services.uploads import UploadState
from schemas.capture import AssetKind, UploadStatus
from schemas.errors import BurnedgeError, ChecksumMismatch, InvalidInput, PayloadTooLarge, UnsupportedMedia

TUS_VERSION = "1.0.0"
CHECKSUMS = {"sha256": hashlib.sha256, "sha1": hashlib.sha1}


class TusVersionUnsupported(BurnedgeError):
    status = 412
    slug = "tus-version"
    title = "Unsupported tus version"


def _require_tus(request: Request) -> None:
    if request.headers.get("tus-resumable") != TUS_VERSION:
        raise TusVersionUnsupported(f"send Tus-Resumable: {TUS_VERSION} (the only version this gateway speaks)")


def parse_metadata(header: str | None) -> dict[str, str]:
    """Upload-Metadata: comma-separated "key base64value" pairs."""
    out: dict[str, str] = {}
    for pair in filter(None, (p.strip() for p in (header or "").split(","))):
        key, _, value = pair.partition(" ")
        try:
            out[key] = base64.b64decode(value, validate=True).decode("utf-8") if value else ""
        except (binascii.Error, UnicodeDecodeError) as exc:
            raise InvalidInput(f"Upload-Metadata value of {key!r} is not base64 UTF-8") from exc
    return out


def _checksum(header: str | None) -> tuple[str, bytes] | None:
    if not header:
        return None
    algo, _, value = header.strip().partition(" ")
    if algo not in CHECKSUMS:
        raise InvalidInput(f"checksum algorithm {algo!r} is not supported: use {' or '.join(CHECKSUMS)}")
    try:
        return algo, base64.b64decode(value, validate=True)
    except binascii.Error as exc:
        raise InvalidInput("Upload-Checksum value is not base64") from exc


def _headers(state: UploadState, offset: int | None = None) -> dict[str, str]:
    return {
        "Tus-Resumable": TUS_VERSION,
        "Upload-Offset": str(state.offset if offset is None else offset),
        "Upload-Expires": format_datetime(state.expires_at, usegmt=True),
        "Cache-Control": "no-store",
    }


class UploadController(Controller):
    path = "/api/v1/uploads"
    tags = ["uploads"]

    # Named to sort before `create`: a Controller registers handlers in name order, and the
    # first handler on a path gets Litestar's automatic OPTIONS handler, which would shadow this one.
    @route("/", http_method=[HttpMethod.OPTIONS], status_code=204, sync_to_thread=False, summary="tus discovery",
           include_in_schema=False)  # fmt: skip
    def capabilities(self, services: ServicesDep) -> Response[None]:
        return Response(None, status_code=204, headers={
            "Tus-Resumable": TUS_VERSION, "Tus-Version": TUS_VERSION,
            "Tus-Extension": "creation,termination,checksum,expiration",
            "Tus-Max-Size": str(services.config.uploads.max_upload_bytes),
            "Tus-Checksum-Algorithm": ",".join(CHECKSUMS),
        })  # fmt: skip

    @post("/", sync_to_thread=True, summary="Start an upload (Upload-Length, Upload-Metadata with encounter_id)")
    def create(
        self, request: AuthedRequest, services: ServicesDep,
        upload_length: Annotated[int, HeaderParameter(name="Upload-Length", ge=0)],
        upload_metadata: Annotated[str | None, HeaderParameter(name="Upload-Metadata")] = None,
    ) -> Response[None]:  # fmt: skip
        _require_tus(request)
        state = services.uploads.create(request.user, upload_length, parse_metadata(upload_metadata))
        return Response(None, status_code=201, headers={**_headers(state), "Location": f"{self.path}/{state.id}"})

    @head("/{upload_id:str}", sync_to_thread=True, summary="How many bytes the gateway holds")
    def offset(self, upload_id: FromPath[str], request: AuthedRequest, services: ServicesDep) -> Response[None]:
        _require_tus(request)
        state = services.uploads.status(request.user, upload_id)
        return Response(None, status_code=200, headers={**_headers(state), "Upload-Length": str(state.length)})

    @route("/{upload_id:str}", http_method=[HttpMethod.PATCH], status_code=204, request_max_body_size=None,
           summary="Send bytes from Upload-Offset (application/offset+octet-stream)")  # fmt: skip
    async def append(
        self, upload_id: FromPath[str], request: AuthedRequest, services: ServicesDep,
        upload_offset: Annotated[int, HeaderParameter(name="Upload-Offset", ge=0)],
        upload_checksum: Annotated[str | None, HeaderParameter(name="Upload-Checksum")] = None,
    ) -> Response[None]:  # fmt: skip
        _require_tus(request)
        if request.headers.get("content-type") != "application/offset+octet-stream":
            raise UnsupportedMedia("send the bytes as Content-Type: application/offset+octet-stream")
        checksum = _checksum(upload_checksum)
        uploads = services.uploads
        part, state = await anyio.to_thread.run_sync(uploads.begin_append, request.user, upload_id, upload_offset)
        try:
            written = await _receive(request, part, upload_offset, state.length, checksum)
        finally:
            uploads.end_append(upload_id)
        end = upload_offset + written
        headers = _headers(state, end)
        if end == state.length:
            asset = await anyio.to_thread.run_sync(uploads.complete, request.user, upload_id)
            headers["Burnedge-Asset-Id"] = asset.id
            if asset.kind is AssetKind.video:
                run_frames_now(request.app.state.scheduler)
            if asset.verdict is not None:
                headers["Burnedge-Accepted"] = "true" if asset.verdict.accepted else "false"
                headers["Burnedge-Reasons"] = ",".join(asset.verdict.reasons)
        return Response(None, status_code=204, headers=headers)

    @delete("/{upload_id:str}", sync_to_thread=True, status_code=204, summary="Abandon an upload (tus termination)")
    def terminate(self, upload_id: FromPath[str], request: AuthedRequest, services: ServicesDep) -> Response[None]:
        _require_tus(request)
        services.uploads.terminate(request.user, upload_id)
        return Response(None, status_code=204, headers={"Tus-Resumable": TUS_VERSION})

    @get("/{upload_id:str}", sync_to_thread=True, summary="The upload, and once complete its asset and quality verdict")
    def read(self, upload_id: FromPath[str], request: AuthedRequest, services: ServicesDep) -> UploadStatus:
        state = services.uploads.status(request.user, upload_id)
        asset = services.assets.get(request.user, state.asset_id) if state.asset_id else None
        return UploadStatus(id=state.id, encounter_id=state.encounter_id, length=state.length, offset=state.offset,
                            state=state.state, expires_at=state.expires_at.isoformat(), asset=asset)  # fmt: skip


async def _receive(request: Request, part, offset: int, length: int, checksum: tuple[str, bytes] | None) -> int:
    """Stream the body into the part file from `offset`; returns the bytes kept.

    A checksummed body is all or nothing; an unchecked one keeps what arrived before a
    dropped connection, which tus then resumes from.
    """
    digest = CHECKSUMS[checksum[0]]() if checksum else None
    written = 0
    disconnected = False
    with open(part, "r+b") as f:
        f.seek(offset)
        try:
            async for chunk in request.stream():
                if offset + written + len(chunk) > length:
                    f.truncate(offset)
                    raise PayloadTooLarge(
                        f"more bytes than the declared Upload-Length of {length}: nothing of this request kept"
                    )
                f.write(chunk)
                written += len(chunk)
                if digest is not None:
                    digest.update(chunk)
        except InternalServerException:  # Litestar's "client disconnected prematurely"
            disconnected = True
        mismatch = digest is not None and not disconnected and digest.digest() != checksum[1]
        if mismatch or (digest is not None and disconnected):
            f.truncate(offset)
            written = 0
        f.flush()
        await anyio.to_thread.run_sync(os.fsync, f.fileno())
    if mismatch:
        raise ChecksumMismatch("the bytes received do not match Upload-Checksum: nothing of this request was kept")
    return written
