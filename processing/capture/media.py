"""What a file is (from its bytes), whether it is whole, and what it says about its capture."""

from __future__ import annotations

from pathlib import Path

import av
from PIL import ExifTags, Image, UnidentifiedImageError

from processing.capture.images import read_header
from schemas.capture import CaptureMetadata, MediaType
from schemas.errors import InvalidInput, UnsupportedMedia

HEIF_BRANDS = {b"heic", b"heix", b"hevc", b"hevx", b"heim", b"heis", b"hevm", b"hevs", b"mif1", b"msf1"}
QUICKTIME_BRANDS = {b"qt  "}
MP4_BRANDS = {b"isom", b"iso2", b"iso4", b"iso5", b"iso6", b"mp41", b"mp42", b"avc1", b"M4V ", b"M4VP", b"3gp4",
              b"3gp5", b"3gp6", b"3g2a", b"dash", b"mmp4", b"MSNV"}  # fmt: skip
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


def check_photo(path: Path, media_type: MediaType, max_pixels: int) -> CaptureMetadata:
    """Refuse truncated or corrupt photos; return their EXIF capture data."""
    data = path.read_bytes()
    header = read_header(data, max_pixels)
    if media_type is MediaType.jpeg and not data.rstrip(b"\x00").endswith(b"\xff\xd9"):
        raise InvalidInput("the JPEG is truncated (no end-of-image marker): upload it again")
    try:
        with Image.open(path) as im:
            if media_type is MediaType.png:
                im.verify()  # every chunk's CRC, without decoding
            else:
                im.draft("L", (max(1, header.width // 8), max(1, header.height // 8)))
                im.load()
            exif = im.getexif() if media_type is not MediaType.png else None
    except (UnidentifiedImageError, OSError, ValueError, SyntaxError) as exc:
        raise InvalidInput(f"the photo is truncated or corrupt: {exc}") from exc
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
        camera_make=text(base.get(ExifTags.Base.Make)),
        camera_model=text(base.get(ExifTags.Base.Model)),
        focal_length_mm=num(sub.get(ExifTags.Base.FocalLength)),
        focal_length_35mm=num(sub.get(ExifTags.Base.FocalLengthIn35mmFilm)),
        orientation=orientation,
        width=width,
        height=height,
    )


def check_video(path: Path) -> CaptureMetadata:
    """Refuse videos that do not open, are not H.264/HEVC, or whose end does not decode."""
    try:
        with av.open(str(path)) as container:
            if not container.streams.video:
                raise InvalidInput("the file has no video track")
            stream = container.streams.video[0]
            codec = stream.codec_context.name
            if codec not in VIDEO_CODECS:
                raise InvalidInput(f"video codec {codec} is not supported: record in H.264 or HEVC (the phone default)")
            duration = float(stream.duration * stream.time_base) if stream.duration else (container.duration or 0) / 1e6
            first = next(container.decode(stream), None)
            if first is None or duration <= 0:
                raise InvalidInput("the video has no decodable frames")
            _decode_near_end(container, stream, duration)
            meta = CaptureMetadata(
                captured_at=container.metadata.get("creation_time"), width=first.width, height=first.height,
                duration_s=round(duration, 3), video_codec=codec,
                frame_rate=round(float(stream.average_rate), 3) if stream.average_rate else None,
                orientation=_rotation(first),
            )  # fmt: skip
    except av.FFmpegError as exc:
        raise InvalidInput(f"the video is truncated or corrupt: {exc}") from exc
    return meta


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
