"""What a file is (from its bytes), whether it is whole, and what it says about its capture."""

from __future__ import annotations

import io
from pathlib import Path

import av
from PIL import ExifTags, Image, UnidentifiedImageError

from processing.capture.images import read_header
from schemas.capture import CaptureMetadata, MediaType
from schemas.config import QualityGateConfig, UploadConfig
from schemas.errors import InvalidInput, UnsupportedMedia, plain

HEIF_BRANDS = {b"heic", b"heix", b"hevc", b"hevx", b"heim", b"heis", b"hevm", b"hevs", b"mif1", b"msf1"}
QUICKTIME_BRANDS = {b"qt  "}
MP4_BRANDS = {
    b"isom",
    b"iso2",
    b"iso4",
    b"iso5",
    b"iso6",
    b"mp41",
    b"mp42",
    b"avc1",
    b"M4V ",
    b"M4VP",
    b"3gp4",
    b"3gp5",
    b"3gp6",
    b"3g2a",
    b"dash",
    b"mmp4",
    b"MSNV",
}
VIDEO_CODECS = {"h264", "hevc"}


def sniff(head: bytes) -> MediaType:
    """The media type from a file's first bytes (32 are enough)."""
    if head.startswith(b"\xff\xd8\xff"):
        return MediaType.jpeg
    if head.startswith(b"\x89PNG\r\n\x1a\n"):
        return MediaType.png
    if len(head) >= 12 and head[4:8] == b"ftyp":
        brand = head[8:12]
        if brand in HEIF_BRANDS:
            return MediaType.heic
        if brand in QUICKTIME_BRANDS:
            return MediaType.quicktime
        if brand in MP4_BRANDS:
            return MediaType.mp4
    if len(head) >= 8 and head[4:8] in (b"moov", b"mdat", b"wide", b"free"):
        return MediaType.quicktime  # QuickTime files from before the ftyp box
    raise UnsupportedMedia(
        "this file is neither a photo (JPEG, PNG, HEIC) nor a video (MP4, MOV), whatever its name says"
    )


def check_photo(data: bytes, media_type: MediaType, max_pixels: int) -> CaptureMetadata:
    """Refuse truncated or corrupt photos; return their EXIF capture data.

    There is no end-of-image marker check: Samsung and Pixel phones append data after it
    (SEF trailers, motion-photo videos). A reduced decode finds truncation instead.
    """
    header = read_header(data, max_pixels)
    try:
        with Image.open(io.BytesIO(data)) as im:
            if media_type is MediaType.png:
                im.verify()  # every chunk's CRC, without decoding
            else:
                if media_type is MediaType.jpeg:  # libjpeg decodes every scan at 1/8 scale
                    im.draft("L", (max(1, header.width // 8), max(1, header.height // 8)))
                # Not for HEIC: pillow-heif's draft decodes an embedded thumbnail instead, proving nothing of the image
                im.load()
            exif = im.getexif() if media_type is not MediaType.png else None
    except (UnidentifiedImageError, OSError, ValueError, SyntaxError) as exc:
        raise InvalidInput(f"the photo is truncated or corrupt: {plain(exc)}") from exc
    return _exif_metadata(exif, header.width, header.height, header.orientation)


def _exif_metadata(exif, width: int, height: int, orientation: int) -> CaptureMetadata:
    base = exif or {}
    sub = exif.get_ifd(ExifTags.IFD.Exif) if exif else {}

    def num(value) -> float | None:
        try:
            return round(float(value), 3) if value is not None else None
        except (TypeError, ValueError, ZeroDivisionError):
            return None

    def text(value) -> str | None:
        return str(value).strip("\x00 ") or None if value is not None else None

    return CaptureMetadata(
        captured_at=text(sub.get(ExifTags.Base.DateTimeOriginal) or base.get(ExifTags.Base.DateTime)),
        captured_offset=text(sub.get(ExifTags.Base.OffsetTimeOriginal))
        if sub.get(ExifTags.Base.DateTimeOriginal)
        else None,
        camera_make=text(base.get(ExifTags.Base.Make)),
        camera_model=text(base.get(ExifTags.Base.Model)),
        focal_length_mm=num(sub.get(ExifTags.Base.FocalLength)),
        focal_length_35mm=num(sub.get(ExifTags.Base.FocalLengthIn35mmFilm)),
        orientation=orientation,
        width=width,
        height=height,
    )


MAX_VIDEO_SIDE = 4096
"""Videos with frames larger than this on a side are refused (phones record 4K at most, 3840x2160)."""


def check_video(
    path: Path, *, limits: QualityGateConfig | None = None, max_seconds: float | None = None
) -> CaptureMetadata:
    """Refuse videos that do not open, are not H.264/HEVC, or whose end does not decode; and videos
    whose frames are smaller than a usable photo (limits.min_width by limits.min_height, either
    way round), larger than MAX_VIDEO_SIDE on a side, or that last more than `max_seconds`.
    The defaults are those of QualityGateConfig() and UploadConfig()."""
    limits = limits or QualityGateConfig()
    max_seconds = UploadConfig().max_video_seconds if max_seconds is None else max_seconds
    try:
        with av.open(str(path)) as container:
            if not container.streams.video:
                raise InvalidInput("the file has no video track")
            stream = container.streams.video[0]
            codec = stream.codec_context.name
            if codec not in VIDEO_CODECS:
                raise InvalidInput(f"video codec {codec} is not supported: record in H.264 or HEVC (the phone default)")
            duration = float(stream.duration * stream.time_base) if stream.duration else (container.duration or 0) / 1e6
            if duration > max_seconds:
                raise InvalidInput(
                    f"the video lasts {duration:.0f} s, longer than the {max_seconds} s allowed: "
                    "film one slow circle around the burn"
                )
            if stream.codec_context.width and stream.codec_context.height:  # from the header, before decoding
                _check_frame_size(stream.codec_context.width, stream.codec_context.height, limits)
            first = next(container.decode(stream), None)
            if first is None or duration <= 0:
                raise InvalidInput("the video has no decodable frames")
            _check_frame_size(first.width, first.height, limits)
            _decode_near_end(container, stream, duration)
            meta = CaptureMetadata(
                captured_at=container.metadata.get("creation_time"),
                width=first.width,
                height=first.height,
                duration_s=round(duration, 3),
                video_codec=codec,
                frame_rate=round(float(stream.average_rate), 3) if stream.average_rate else None,
                orientation=_rotation(first),
            )
    except av.FFmpegError as exc:
        raise InvalidInput(f"the video is truncated, corrupt or not a video: {plain(exc)}") from exc
    return meta


def _check_frame_size(width: int, height: int, limits: QualityGateConfig) -> None:
    if max(width, height) > MAX_VIDEO_SIDE:
        raise InvalidInput(
            f"the video is {width}x{height} pixels, more than {MAX_VIDEO_SIDE} on a side: record at 4K or less"
        )
    if max(width, height) < limits.min_width or min(width, height) < limits.min_height:
        raise InvalidInput(
            f"the video is {width}x{height} pixels, smaller than a usable photo "
            f"({limits.min_width}x{limits.min_height}): record at 720p or more"
        )


def _decode_near_end(container, stream, duration: float) -> None:
    """A truncated recording still opens; its last second does not decode."""
    target = max(0.0, duration - 1.0)
    container.seek(int(target / stream.time_base), stream=stream, backward=True)
    decoded = 0
    for frame in container.decode(stream):
        decoded += 1
        if frame.time is not None and frame.time >= target:
            return
    if decoded == 0:
        raise InvalidInput("the end of the video does not decode: the recording is truncated")
    raise InvalidInput("the video stops before its stated length: the recording is truncated")


def _rotation(frame) -> int | None:
    rotation = getattr(frame, "rotation", None)
    return int(rotation) if rotation else None
