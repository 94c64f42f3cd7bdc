"""When a visit's pictures were taken, which the hours since injury (and so `provisional`) count to.

A clinic may analyse photos days after it took them (no power, a queue, a consultant asking later), so the time
of the analysis request says nothing about the burn's age. Each picture's own clock is used where it is
plausible (EXIF DateTimeOriginal with its offset, or in the phones' configured time zone; a video's creation
time for its frames), else the time it reached the gateway. The visit's time is the earliest picture's: a
later one would make the burn look older, and a result less provisional, than it is.
"""

from __future__ import annotations

import datetime as dt
import re
import zoneinfo
from collections import Counter

from schemas.base import counted, iso
from schemas.capture import Asset, CaptureMetadata
from schemas.config import AnalysisConfig
from schemas.jobs import CaptureTime, CaptureTimeSource

AFTER_UPLOAD_SLACK = dt.timedelta(minutes=10)
"""A camera time later than the upload by more than this is a wrong clock (or a zone off) and is not used."""
BEFORE_INJURY_SLACK = dt.timedelta(hours=1)
"""The recorded time of injury is often an estimate; a picture this much before it is a wrong clock."""
OLDEST = dt.timedelta(days=365)
"""A camera time over this long before the upload is a clock never set (phones reset to 1970 or 2000)."""

_EXIF = re.compile(r"\A(\d{4}):(\d\d):(\d\d)[ T](\d\d:\d\d:\d\d)")


def camera_zone(conf: AnalysisConfig) -> dt.tzinfo:
    if conf.camera_time_zone:
        return zoneinfo.ZoneInfo(conf.camera_time_zone)
    return dt.datetime.now().astimezone().tzinfo or dt.UTC


def camera_time(metadata: CaptureMetadata, zone: dt.tzinfo) -> dt.datetime | None:
    """The picture's own time as an aware datetime; None when it has none or it does not parse."""
    text = (metadata.captured_at or "").strip()
    exif = _EXIF.match(text)
    if exif:
        text = f"{exif[1]}-{exif[2]}-{exif[3]}T{exif[4]}"
        if metadata.captured_offset:
            text += metadata.captured_offset.strip()
    try:
        when = dt.datetime.fromisoformat(text.replace("Z", "+00:00"))
    except ValueError:  # empty, '0000:00:00 00:00:00', or something no camera writes
        return None
    return when if when.tzinfo is not None else when.replace(tzinfo=zone)


def _picture_time(asset: Asset, injury: dt.datetime | None, zone: dt.tzinfo) -> tuple[dt.datetime, str]:
    """(when, why): why is 'camera' when its own clock was used, else why not."""
    uploaded = dt.datetime.fromisoformat(asset.created_at)
    own = camera_time(asset.metadata, zone)
    if own is None:
        return uploaded, "no camera time"
    if own > uploaded + AFTER_UPLOAD_SLACK:
        return uploaded, "camera time after the upload"
    if own < uploaded - OLDEST:
        return uploaded, "camera time over a year before the upload"
    if injury is not None and own < injury - BEFORE_INJURY_SLACK:
        return uploaded, "camera time before the injury"
    return own, "camera"


def capture_time(pictures: list[Asset], injury: dt.datetime | None, conf: AnalysisConfig) -> CaptureTime:
    """When the visit's pictures were taken (the earliest picture), where that came from, and in words why."""
    zone = camera_zone(conf)
    times = [_picture_time(p, injury, zone) for p in pictures]
    earliest, why = min(times, key=lambda t: t[0])
    reasons = Counter(reason for _, reason in times)
    own = reasons.pop("camera", 0)
    others = ", ".join(f"{n}: {reason}" for reason, n in sorted(reasons.items()))
    if why == "camera":
        detail = f"camera clock of {own} of {len(times)} pictures" + (f" ({others})" if others else "")
        return CaptureTime(at=iso(earliest.astimezone(dt.UTC)), source=CaptureTimeSource.camera, detail=detail)
    detail = "upload time" + (f": {others}" if others else "")
    if own:
        detail += f"; {counted(own, 'camera time')} later than the earliest upload"
    return CaptureTime(at=iso(earliest.astimezone(dt.UTC)), source=CaptureTimeSource.upload, detail=detail)


def hours_since_injury(taken: str, injury: dt.datetime) -> float:
    """From the injury to `taken` (ISO 8601, e.g. CaptureTime.at), never negative."""
    return max(0.0, (dt.datetime.fromisoformat(taken) - injury).total_seconds() / 3600)
