"""A capture time the phone states beside a picture (tus Upload-Metadata captured_at), for pictures whose file
carries none: a still taken from the browser's camera stream has no EXIF. Kept in the form a camera writes (EXIF
DateTimeOriginal and OffsetTimeOriginal), so everything that reads a picture's time reads it the same way; a time in
the file itself always wins."""

from __future__ import annotations

import datetime as dt

import msgspec

from schemas.capture import CaptureMetadata
from schemas.errors import InvalidInput


def exif_form(stated: str) -> tuple[str, str]:
    """('YYYY:MM:DD HH:MM:SS', '+HH:MM') of an ISO 8601 time with its offset; InvalidInput for anything else."""
    try:
        when = dt.datetime.fromisoformat(stated.strip().replace("Z", "+00:00"))
    except ValueError as exc:
        raise InvalidInput(
            f"Upload-Metadata captured_at {stated[:40]!r} is not an ISO 8601 time (2026-12-06T08:10:00+01:00)"
        ) from exc
    offset = when.utcoffset()
    if offset is None:
        raise InvalidInput("Upload-Metadata captured_at needs its UTC offset (…+01:00 or …Z): the phone knows it")
    minutes = int(offset.total_seconds() // 60)
    sign = "+" if minutes >= 0 else "-"
    return when.strftime("%Y:%m:%d %H:%M:%S"), f"{sign}{abs(minutes) // 60:02d}:{abs(minutes) % 60:02d}"


def with_stated_time(metadata: CaptureMetadata, stated: str | None) -> CaptureMetadata:
    """`metadata` with the phone's stated time when the file has none of its own."""
    if not stated or metadata.captured_at:
        return metadata
    at, offset = exif_form(stated)
    return msgspec.structs.replace(metadata, captured_at=at, captured_offset=offset)
