"""Writing a capture time into a JPEG, as a phone's camera does, without re-encoding its pixels.

The demo and the tests take rendered pictures "on" a visit's day: the gateway then reads the time the way it
reads a phone's (EXIF DateTimeOriginal and OffsetTimeOriginal).
"""

from __future__ import annotations

import datetime as dt
import struct

from PIL import ExifTags, Image

from schemas.errors import InvalidInput


def _offset(when: dt.datetime) -> str:
    minutes = int(when.utcoffset().total_seconds() // 60)
    sign = "+" if minutes >= 0 else "-"
    return f"{sign}{abs(minutes) // 60:02d}:{abs(minutes) % 60:02d}"


def with_capture_time(jpeg: bytes, when: dt.datetime, *, offset: bool = True) -> bytes:
    """`jpeg` with an EXIF block saying it was taken at `when` (aware); without `offset` the time is written as
    the local clock reading only, as older phones do."""
    if jpeg[:2] != b"\xff\xd8":
        raise InvalidInput("not a JPEG: only JPEG pictures can be given a capture time")
    if when.tzinfo is None:
        raise InvalidInput("the capture time needs a time zone")
    exif = Image.Exif()
    sub = exif.get_ifd(ExifTags.IFD.Exif)
    sub[ExifTags.Base.DateTimeOriginal] = when.strftime("%Y:%m:%d %H:%M:%S")
    if offset:
        sub[ExifTags.Base.OffsetTimeOriginal] = _offset(when)
    payload = b"Exif\x00\x00" + exif.tobytes()
    return jpeg[:2] + b"\xff\xe1" + struct.pack(">H", len(payload) + 2) + payload + jpeg[2:]
