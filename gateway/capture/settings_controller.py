"""What a phone needs before it captures, without signing in (neither holds patient data): the gateway's capture
settings, so the app checks each preview frame by the gateway's own thresholds, and the printable marker sheet."""

from __future__ import annotations

import functools
from typing import Annotated

import cv2
from litestar import Controller, Response, get
from litestar.params import Parameter

from gateway.dependencies import ServicesDep
from processing.capture.quality import GUIDANCE
from processing.report import marker_sheet
from processing.report.marker_sheet import Paper
from schemas.capture import REJECTING, CaptureSettings, MarkerSpec

SHEET_PATH = "/marker-sheet.pdf"


@functools.lru_cache(maxsize=8)
def _sheet(dictionary: str, side_mm: float, paper: Paper) -> bytes:
    return marker_sheet.render(dictionary, side_mm, paper)


@functools.lru_cache(maxsize=4)
def _marker(dictionary: str, side_mm: float) -> MarkerSpec:
    aruco = marker_sheet.aruco_dictionary(dictionary)
    size = aruco.markerSize
    codes = []
    for marker_id in range(aruco.bytesList.shape[0]):
        bits = cv2.aruco.Dictionary.getBitsFromByteList(aruco.bytesList[marker_id : marker_id + 1], size)
        codes.append(format(int("".join(str(int(b)) for b in bits.ravel()), 2), "x"))
    return MarkerSpec(
        dictionary=dictionary,
        side_mm=side_mm,
        sheet=SHEET_PATH,
        bits=size * size,
        max_correction_bits=int(aruco.maxCorrectionBits),
        codes=codes,
    )


class CaptureSettingsController(Controller):
    path = "/"
    tags = ["capture"]

    @get(
        "/api/v1/capture/settings",
        sync_to_thread=False,
        exclude_from_auth=True,
        summary="The quality gate's thresholds, the readiness rules and the scale marker, for a phone's checks",
        cache=60,
    )
    def settings(self, services: ServicesDep) -> CaptureSettings:
        config = services.config
        return CaptureSettings(
            quality=config.quality,
            readiness=config.readiness,
            marker=_marker(config.reconstruction.marker_dictionary, config.reconstruction.marker_side_mm),
            max_upload_bytes=config.uploads.max_upload_bytes,
            rejecting=sorted(REJECTING),
            guidance=GUIDANCE,
        )

    @get(
        SHEET_PATH,
        sync_to_thread=True,
        exclude_from_auth=True,
        summary="The printable scale marker sheet (PDF): strips of three markers and a 10 cm check line",
        media_type="application/pdf",
        include_in_schema=False,  # a document for people, answered as a page (its errors too), like the pages
    )
    def sheet(
        self,
        services: ServicesDep,
        paper: Annotated[Paper, Parameter(description="a4 (default) or letter")] = Paper.a4,
    ) -> Response[bytes]:
        config = services.config.reconstruction
        pdf = _sheet(config.marker_dictionary, config.marker_side_mm, paper)
        return Response(
            pdf,
            media_type="application/pdf",
            headers={
                "Content-Disposition": f'inline; filename="burnedge-marker-sheet-{paper.value}.pdf"',
                "Cache-Control": "public, max-age=3600",
            },
        )
