"""Resumable uploads over the tus 1.0 protocol (core, creation, termination, checksum, expiration).

Existing mobile tus clients work unchanged: send the session token as a header, the
encounter in Upload-Metadata (`encounter_id`, plus `filename`), and the bytes in PATCHes
(or POSTs with X-HTTP-Method-Override, for clients on platforms without PATCH). The last
PATCH's answer carries the stored asset and its quality verdict in headers
(Burnedge-Asset-Id, Burnedge-Accepted, Burnedge-Reasons); GET on the upload gives it all.
"""

from __future__ import annotations

import base64
import binascii
import hashlib
import os
from email.utils import format_datetime
from pathlib import Path
from typing import Annotated

import anyio
from litestar import Controller, Request, Response, delete, get, head, post, route
from litestar.enums import HttpMethod
from litestar.exceptions import InternalServerException
from litestar.params import HeaderParameter

from base.web.paths import IdPath
from base.web.problems import ONE, problems
from base.web.site import AuthedRequest
from gateway.capture.uploads import UploadState
from gateway.dependencies import ServicesDep
from gateway.scheduler import run_frames_now
from schemas.capture import TUS_VERSION, AssetKind, UploadStatus
from schemas.errors import (
    BadRequest,
    ChecksumMismatch,
    InvalidInput,
    PayloadTooLarge,
    TusVersionUnsupported,
    UnsupportedMedia,
)

CHECKSUMS = {"sha256": hashlib.sha256, "sha1": hashlib.sha1}
WRITE_BATCH = 256 * 1024
"""Bytes gathered before each write to disk, which runs off the event loop."""


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
        raise BadRequest(f"checksum algorithm {algo!r} is not supported: use {' or '.join(CHECKSUMS)}")
    try:
        return algo, base64.b64decode(value, validate=True)
    except binascii.Error as exc:
        raise BadRequest("Upload-Checksum value is not base64") from exc


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
    @route(
        "/",
        http_method=[HttpMethod.OPTIONS],
        status_code=204,
        sync_to_thread=False,
        summary="tus discovery",
        include_in_schema=False,
    )
    def capabilities(self, services: ServicesDep) -> Response[None]:
        return Response(
            None,
            status_code=204,
            headers={
                "Tus-Resumable": TUS_VERSION,
                "Tus-Version": TUS_VERSION,
                "Tus-Extension": "creation,termination,checksum,expiration",
                "Tus-Max-Size": str(services.config.uploads.max_upload_bytes),
                "Tus-Checksum-Algorithm": ",".join(CHECKSUMS),
            },
        )

    @post(
        "/",
        sync_to_thread=True,
        summary="Start an upload (Upload-Length, Upload-Metadata with encounter_id)",
        responses=problems(*ONE, 412, 413, 422, 429, 507),
    )
    def create(
        self,
        request: AuthedRequest,
        services: ServicesDep,
        upload_length: Annotated[int, HeaderParameter(name="Upload-Length", ge=0)],
        upload_metadata: Annotated[str | None, HeaderParameter(name="Upload-Metadata")] = None,
    ) -> Response[None]:
        _require_tus(request)
        state = services.uploads.create(request.user, upload_length, parse_metadata(upload_metadata))
        location = f"{str(request.base_url).rstrip('/')}{self.path}/{state.id}"
        return Response(None, status_code=201, headers={**_headers(state), "Location": location})

    @head(
        "/{upload_id:str}",
        sync_to_thread=True,
        summary="How many bytes the gateway holds",
        responses=problems(*ONE, 410, 412),
    )
    def offset(self, upload_id: IdPath, request: AuthedRequest, services: ServicesDep) -> Response[None]:
        _require_tus(request)
        state = services.uploads.status(request.user, upload_id)
        return Response(None, status_code=200, headers={**_headers(state), "Upload-Length": str(state.length)})

    @route(
        "/{upload_id:str}",
        http_method=[HttpMethod.PATCH],
        status_code=204,
        request_max_body_size=None,
        summary="Send bytes from Upload-Offset (application/offset+octet-stream)",
        responses=problems(*ONE, 409, 410, 412, 413, 415, 422, 460),
    )
    async def append(
        self,
        upload_id: IdPath,
        request: AuthedRequest,
        services: ServicesDep,
        upload_offset: Annotated[int, HeaderParameter(name="Upload-Offset", ge=0)],
        upload_checksum: Annotated[str | None, HeaderParameter(name="Upload-Checksum")] = None,
    ) -> Response[None]:
        return await _append(request, services, upload_id, upload_offset, upload_checksum)

    @post("/{upload_id:str}", status_code=204, request_max_body_size=None, include_in_schema=False)
    async def overridden(
        self,
        upload_id: IdPath,
        request: AuthedRequest,
        services: ServicesDep,
        method: Annotated[str, HeaderParameter(name="X-HTTP-Method-Override")],
        upload_offset: Annotated[int | None, HeaderParameter(name="Upload-Offset", ge=0)] = None,
        upload_checksum: Annotated[str | None, HeaderParameter(name="Upload-Checksum")] = None,
    ) -> Response[None]:
        """tus clients on platforms without PATCH (or DELETE) send a POST that names the method."""
        if method.upper() == "PATCH" and upload_offset is not None:
            return await _append(request, services, upload_id, upload_offset, upload_checksum)
        if method.upper() == "DELETE":
            _require_tus(request)
            await anyio.to_thread.run_sync(services.uploads.terminate, request.user, upload_id)
            return Response(None, status_code=204, headers={"Tus-Resumable": TUS_VERSION})
        raise BadRequest("X-HTTP-Method-Override must be PATCH (with Upload-Offset) or DELETE")

    @delete(
        "/{upload_id:str}",
        sync_to_thread=True,
        status_code=204,
        summary="Abandon an upload (tus termination)",
        responses=problems(*ONE, 409, 410, 412),
    )
    def terminate(self, upload_id: IdPath, request: AuthedRequest, services: ServicesDep) -> Response[None]:
        _require_tus(request)
        services.uploads.terminate(request.user, upload_id)
        return Response(None, status_code=204, headers={"Tus-Resumable": TUS_VERSION})

    @get(
        "/{upload_id:str}",
        sync_to_thread=True,
        summary="The upload, and once complete its asset and quality verdict",
        responses=problems(*ONE, 410),
    )
    def read(self, upload_id: IdPath, request: AuthedRequest, services: ServicesDep) -> UploadStatus:
        state = services.uploads.status(request.user, upload_id)
        asset = services.assets.get(request.user, state.asset_id) if state.asset_id else None
        return UploadStatus(
            id=state.id,
            encounter_id=state.encounter_id,
            length=state.length,
            offset=state.offset,
            state=state.phase,
            expires_at=state.expires_at.isoformat(),
            asset=asset,
        )


async def _append(
    request: Request, services, upload_id: str, offset: int, checksum_header: str | None
) -> Response[None]:
    _require_tus(request)
    if request.headers.get("content-type") != "application/offset+octet-stream":
        raise UnsupportedMedia("send the bytes as Content-Type: application/offset+octet-stream")
    checksum = _checksum(checksum_header)
    uploads = services.uploads
    with uploads.claim(upload_id):  # held until completion is over
        part, state = await anyio.to_thread.run_sync(uploads.open_for_append, request.user, upload_id, offset)
        timeout = services.config.uploads.receive_timeout_s
        written = await _receive(request, part, offset, state.length, checksum, timeout)
        end = offset + written
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


async def _receive(
    request: Request, part: Path, offset: int, length: int, checksum: tuple[str, bytes] | None, timeout: float
) -> int:
    """Stream the body into the part file from `offset`; returns the bytes kept.

    A checksummed body is all or nothing; an unchecked one keeps what arrived before a
    dropped or stalled connection, which tus then resumes from.
    """
    digest = CHECKSUMS[checksum[0]]() if checksum else None
    written, pending, dropped = 0, [], False
    chunks = request.stream().__aiter__()
    with open(part, "r+b") as f:
        f.seek(offset)
        try:
            while True:
                try:
                    with anyio.fail_after(timeout):
                        chunk = await chunks.__anext__()
                except StopAsyncIteration:
                    break
                if offset + written + sum(map(len, pending)) + len(chunk) > length:
                    f.truncate(offset)
                    raise PayloadTooLarge(
                        f"more bytes than the declared Upload-Length of {length}: nothing of this request kept"
                    )
                pending.append(chunk)
                if digest is not None:
                    digest.update(chunk)
                if sum(map(len, pending)) >= WRITE_BATCH:
                    written += await anyio.to_thread.run_sync(f.write, b"".join(pending))
                    pending = []
        except (InternalServerException, TimeoutError):  # client gone, or silent for `timeout` seconds
            dropped = True
        if pending:
            written += await anyio.to_thread.run_sync(f.write, b"".join(pending))
        mismatch = digest is not None and not dropped and digest.digest() != checksum[1]
        if mismatch or (digest is not None and dropped):
            f.truncate(offset)
            written = 0
        f.flush()
        await anyio.to_thread.run_sync(os.fsync, f.fileno())
    if mismatch:
        raise ChecksumMismatch("the bytes received do not match Upload-Checksum: nothing of this request was kept")
    return written
