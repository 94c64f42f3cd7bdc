"""Capture intake: the quality verdict on each photo or video frame, and the stored assets."""

from __future__ import annotations

import datetime as dt
import enum
from typing import Annotated

import msgspec

from schemas.base import Frozen, ShortText
from schemas.config import QualityGateConfig, ReadinessConfig

TUS_VERSION = "1.0.0"
"""The tus protocol version the gateway speaks."""


class QualityReason(enum.StrEnum):
    """Machine-readable reasons on a quality verdict."""

    unreadable = "unreadable"
    """Not a decodable image."""
    too_small = "too_small"
    """Below the minimum resolution (800 x 600 by default)."""
    blurry = "blurry"
    """Too little sharpness where the burn usually is (camera shake or missed focus)."""
    too_dark = "too_dark"
    too_bright = "too_bright"
    no_marker = "no_marker"
    """No scale marker found; the photo stays usable for reconstruction, not for measuring alone."""
    marker_too_small = "marker_too_small"
    """The marker is so small in the picture that the scale would be imprecise."""


REJECTING = frozenset(
    {
        QualityReason.unreadable,
        QualityReason.too_small,
        QualityReason.blurry,
        QualityReason.too_dark,
        QualityReason.too_bright,
    }
)
"""Reasons that make a picture unusable for reconstruction; the others only advise."""


class MarkerSighting(Frozen):
    id: int
    side_px: float
    """Mean side length in pixels of the full-resolution image."""
    corners_px: list[list[float]]
    """Four corners (x, y) in full-resolution pixels, in ArUco order."""


class QualityFigures(Frozen):
    """What the gate measured, so a person can see why."""

    width: int
    height: int
    analysis_long_side: int
    """Long side, in pixels, of the image the figures below were computed on."""
    sharpness: float
    """Variance of the Laplacian over the whole image, at the analysis scale."""
    local_sharpness: float
    """75th percentile of the Laplacian variance over the tiles of the central region."""
    mean_intensity: float
    """Mean grey level, 0-255."""
    dark_fraction: float
    """Share of pixels at or below the dark clipping level."""
    bright_fraction: float
    """Share of pixels at or above the bright clipping level."""
    markers: list[MarkerSighting]
    seconds: float
    """Time the gate took for this picture."""


class QualityVerdict(Frozen):
    """Whether a picture is usable, why not, and what to do about it."""

    file: str
    accepted: bool
    """Usable for reconstruction (a missing marker alone does not make a picture unusable)."""
    reasons: list[QualityReason]
    guidance: list[str]
    """Sentences for the person holding the phone."""
    figures: QualityFigures | None
    """None when the file could not be decoded."""


class MediaType(enum.StrEnum):
    """What a file really is, judged from its bytes (never its name)."""

    jpeg = "image/jpeg"
    png = "image/png"
    heic = "image/heic"
    mp4 = "video/mp4"
    quicktime = "video/quicktime"

    @property
    def is_video(self) -> bool:
        return self in (MediaType.mp4, MediaType.quicktime)


class AssetKind(enum.StrEnum):
    photo = "photo"
    video = "video"
    frame = "frame"
    """A still taken from a video by the gateway."""


class CaptureMetadata(Frozen, omit_defaults=True):
    """What the file says about how it was taken (EXIF or the video container)."""

    captured_at: str | None = None
    """As the camera wrote it (EXIF DateTimeOriginal has no time zone: see captured_offset)."""
    captured_offset: str | None = None
    """EXIF OffsetTimeOriginal ('+02:00'), when the camera wrote one."""
    camera_make: str | None = None
    camera_model: str | None = None
    focal_length_mm: float | None = None
    focal_length_35mm: float | None = None
    orientation: int | None = None
    """EXIF orientation (1 = as stored); for video, the rotation in degrees."""
    width: int | None = None
    height: int | None = None
    duration_s: float | None = None
    video_codec: str | None = None
    frame_rate: float | None = None


class SetAside(Frozen):
    """Why a picture no longer counts (for readiness, analyses and the case sent): set aside by a person, never
    deleted, and it can be put back."""

    reason: ShortText
    by: str
    at: dt.datetime


class SetAsideBody(Frozen):
    """POST /api/v1/assets/{id}/set-aside."""

    reason: Annotated[str, msgspec.Meta(min_length=1, max_length=200)]
    """Why it should not count, e.g. "blurred" or "wrong patient"."""


class Asset(Frozen):
    """A stored photo, video or extracted frame, linked to its encounter. The bytes are kept as received."""

    id: str
    encounter_id: str
    kind: AssetKind
    media_type: MediaType
    sha256: str
    """Of the original bytes; the file is stored under this name."""
    size_bytes: int
    filename: str
    """The name the phone gave, for people; never used as a path."""
    metadata: CaptureMetadata
    verdict: QualityVerdict | None
    """For photos and frames."""
    source_asset_id: str | None
    """For a frame: the video it was taken from."""
    created_at: str
    created_by: str
    device_id: str | None
    wound_id: str | None = None
    """The wound it shows (Upload-Metadata wound_id, or set later); None when not said. A frame takes its
    video's."""
    set_aside: SetAside | None = None
    """Set when a person set it aside; a video's frames follow it."""


class UploadPhase(enum.StrEnum):
    open = "open"
    """Receiving bytes (or all received and being checked)."""
    complete = "complete"
    failed = "failed"
    terminated = "terminated"
    expired = "expired"


class StoredUpload(Frozen):
    """An upload as the gateway's database holds it (the bytes so far are in its .part file)."""

    id: str
    encounter_id: str
    length: int
    """The whole file's size, as the phone announced it."""
    metadata: dict[str, str]
    """The tus Upload-Metadata, as sent."""
    filename: str
    state: UploadPhase
    created_by: str
    """The user id of who started it."""
    device_id: str | None
    created_at: str
    expires_at: str
    asset_id: str | None
    """Once complete: the asset it was stored as."""
    error: str | None
    """Why it failed, when it did."""


class UploadStatus(Frozen):
    """An upload as the gateway holds it (GET /api/v1/uploads/{id}); tus clients use HEAD instead."""

    id: str
    encounter_id: str
    length: int
    offset: int
    state: UploadPhase
    expires_at: str
    asset: Asset | None
    """Once complete: the stored file, with its quality verdict for a photo."""


class CaptureReadiness(Frozen):
    """Whether an encounter's photos and frames are enough for 3D analysis, and what is missing."""

    ready: bool
    views: int
    """Photos and frames received."""
    accepted_views: int
    marker_views: int
    """Accepted views in which the scale marker was found."""
    viewpoint_spread_deg: float | None
    """Largest angle between viewing directions, from the marker poses; None with fewer than two marker views."""
    missing: list[str]
    """What to do, in sentences, when not ready."""


class MarkerSpec(Frozen):
    """The printed scale marker the gateway measures with."""

    dictionary: str
    """ArUco dictionary (an OpenCV name, e.g. DICT_4X4_50)."""
    side_mm: float
    """Printed side of one marker, outer black edge to outer black edge."""
    sheet: str
    """Where to print it: the sheet of strips with a 10 cm check line."""
    bits: int
    """Bits per marker (16 for a 4x4 dictionary)."""
    max_correction_bits: int
    """Bit errors the dictionary can correct."""
    codes: list[str]
    """Each marker id's bits, read row by row from the top left (black = 1), as hexadecimal: a phone's detector
    reads the same dictionary as the gateway's."""


class CaptureSettings(Frozen):
    """What a phone checks before a picture leaves the bedside: the gateway's own gate thresholds, readiness rules and
    marker, served so the app and the gateway judge by one source (GET /api/v1/capture/settings)."""

    quality: QualityGateConfig
    readiness: ReadinessConfig
    marker: MarkerSpec
    max_upload_bytes: int
    """Largest photo or video the gateway takes in one upload."""
    rejecting: list[QualityReason]
    """Reasons that make a picture unusable for reconstruction; the others only advise."""
    guidance: dict[QualityReason, str]
    """What to tell the person holding the phone, for each reason."""
