"""When a visit's pictures were taken: the camera's own clock where it is plausible, else the upload time; the
hours since injury (and `provisional`) count to it, however late the analysis runs."""

from __future__ import annotations

import datetime as dt
import io

import numpy as np
import pytest
from PIL import Image

from gateway.jobs.capture_time import camera_time, capture_time, hours_since_injury
from processing.capture.media import check_photo
from processing.capture.stamp import with_capture_time
from schemas.base import iso
from schemas.capture import Asset, AssetKind, CaptureMetadata, MediaType
from schemas.config import AnalysisConfig
from schemas.errors import InvalidInput
from schemas.jobs import CaptureTimeSource

NAIROBI = AnalysisConfig(camera_time_zone="Africa/Nairobi")  # UTC+3 all year
INJURY = dt.datetime(2026, 11, 10, 6, 0, tzinfo=dt.UTC)
UPLOADED = INJURY + dt.timedelta(days=20)


def jpeg() -> bytes:
    out = io.BytesIO()
    Image.fromarray(np.full((48, 64, 3), 128, np.uint8)).save(out, "JPEG")
    return out.getvalue()


def picture(captured_at: str | None, offset: str | None = None, uploaded: dt.datetime = UPLOADED) -> Asset:
    return Asset(
        id="0192f3b4-6a8f-7000-8000-000000000001",
        encounter_id="e",
        kind=AssetKind.photo,
        media_type=MediaType.jpeg,
        sha256="0" * 64,
        size_bytes=1,
        filename="p.jpg",
        metadata=CaptureMetadata(captured_at=captured_at, captured_offset=offset),
        verdict=None,
        source_asset_id=None,
        created_at=iso(uploaded),
        created_by="dr",
        device_id=None,
    )


def test_a_stamped_jpeg_reads_back_its_time_and_offset_through_the_upload_check():
    taken = dt.datetime(2026, 11, 10, 12, 30, 5, tzinfo=dt.timezone(dt.timedelta(hours=2)))
    metadata = check_photo(with_capture_time(jpeg(), taken), MediaType.jpeg, 10**8)
    assert (metadata.captured_at, metadata.captured_offset) == ("2026:11:10 12:30:05", "+02:00")
    assert camera_time(metadata, dt.UTC) == taken
    bare = check_photo(with_capture_time(jpeg(), taken, offset=False), MediaType.jpeg, 10**8)
    assert bare.captured_offset is None  # an older phone: the clock reading only, in the configured zone
    assert camera_time(bare, dt.timezone(dt.timedelta(hours=2))) == taken
    with pytest.raises(InvalidInput, match="not a JPEG"):
        with_capture_time(b"\x89PNG....", taken)


def test_a_day_0_visit_analysed_20_days_later_counts_to_the_camera_clock():
    taken = INJURY + dt.timedelta(hours=3)
    local = taken.astimezone(dt.timezone(dt.timedelta(hours=3))).strftime("%Y:%m:%d %H:%M:%S")
    captured = capture_time([picture(local), picture(local)], INJURY, NAIROBI)
    assert captured.source is CaptureTimeSource.camera and captured.detail == "camera clock of 2 of 2 pictures"
    assert hours_since_injury(captured.at, INJURY) == pytest.approx(3.0)
    assert hours_since_injury(captured.at, INJURY) < NAIROBI.provisional_hours  # still provisional


def test_the_earliest_picture_counts_and_an_offset_beats_the_configured_zone():
    early = picture("2026:11:10 10:00:00", "+01:00")  # 09:00 UTC
    late = picture("2026:11:10 15:00:00")  # Nairobi: 12:00 UTC
    captured = capture_time([late, early], INJURY, NAIROBI)
    assert captured.at == iso(dt.datetime(2026, 11, 10, 9, 0, tzinfo=dt.UTC))


@pytest.mark.parametrize(
    ("taken", "why"),
    [
        (None, "no camera time"),
        ("0000:00:00 00:00:00", "no camera time"),
        ("2026:12:01 06:00:00", "camera time after the upload"),  # the phone's clock runs 10 days ahead
        ("2024:01:01 00:00:00", "camera time over a year before the upload"),
        ("2026:11:09 12:00:00", "camera time before the injury"),
    ],
)
def test_an_implausible_or_missing_camera_time_falls_back_to_the_upload(taken, why):
    captured = capture_time([picture(taken)], INJURY, NAIROBI)
    assert captured.source is CaptureTimeSource.upload and captured.detail == f"upload time: 1: {why}"
    assert captured.at == iso(UPLOADED)


def test_a_video_frame_uses_the_containers_creation_time():
    frame = picture("2026-11-10T09:15:00.000000Z")
    captured = capture_time([frame], INJURY, NAIROBI)
    assert captured.source is CaptureTimeSource.camera and hours_since_injury(captured.at, INJURY) == pytest.approx(
        3.25
    )


def test_mixed_pictures_say_which_had_a_camera_time():
    captured = capture_time([picture("2026:11:10 12:00:00"), picture(None)], INJURY, NAIROBI)
    assert captured.source is CaptureTimeSource.camera
    assert captured.detail == "camera clock of 1 of 2 pictures (1: no camera time)"


def test_an_unknown_time_zone_name_is_refused_in_the_config():
    import msgspec

    with pytest.raises(msgspec.ValidationError, match="not a time zone name"):
        msgspec.convert({"camera_time_zone": "Mars/Olympus"}, AnalysisConfig)
