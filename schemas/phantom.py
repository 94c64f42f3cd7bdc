"""Burn phantoms: the spec a phantom scene is rendered from, and the ground truth it comes with.

A phantom is a multi-view photo set of a skin-textured body part carrying a burn of exactly
known geometry (processing/phantom). `PhantomTruth` names the ground-truth fields our own
evaluation code reads; it ignores fields it does not name, so the same code reads the scenes
of the independent generator in ../shared/phantoms.
"""

from __future__ import annotations

import enum
from typing import Annotated, Any

import msgspec

from schemas.base import Frozen, Message

PHANTOM_FORMAT = "burnedge-phantom/1"
"""`format` of a scene's ground_truth.json."""
PHANTOM_SERIES_FORMAT = "burnedge-phantom-series/1"
"""`format` of a series' top-level ground_truth.json."""


class PhantomShape(enum.StrEnum):
    """The body part the burn is on."""

    forearm = "forearm"
    """A tapered elliptic cylinder lying on the drape."""
    patch = "patch"
    """A larger, gently curved dome, like a thigh or a back."""
    foot = "foot"
    """A boxy dome with smooth bumps, like the top of a foot."""


class SkinTone(enum.StrEnum):
    """Fitzpatrick-like skin types: base colours from very fair (I) to deeply pigmented (VI)."""

    I = "I"  # noqa: E741
    II = "II"
    III = "III"
    IV = "IV"
    V = "V"
    VI = "VI"


class BurnLook(enum.StrEnum):
    """How the burn looks, roughly following the clinical depth classes (appearance only: no crater implied)."""

    mixed = "mixed"
    """Red and pink with white mottling, tan patches, a few blisters and dark specks (the default)."""
    superficial = "superficial"
    """Pink to bright red, moist, many blisters, no white or eschar."""
    deep_partial = "deep_partial"
    """Mottled deep red and waxy white, fewer blisters."""
    full_thickness = "full_thickness"
    """Leathery white to tan with dark eschar, no blisters."""


class PhantomSpec(Message):
    """Everything a phantom scene is rendered from; the same spec and seed give the same files."""

    shape: PhantomShape = PhantomShape.forearm
    """Body part carrying the burn."""
    seed: Annotated[int, msgspec.Meta(ge=0, le=2**32 - 1)] = 0
    """Seeds every random choice: body part proportions, burn outline, textures, lights, cameras, noise."""
    views: Annotated[int, msgspec.Meta(ge=6, le=20)] = 12
    """Number of photos, taken from around the burn."""
    width: Annotated[int, msgspec.Meta(ge=320, le=8192)] = 1920
    """Image width in pixels."""
    height: Annotated[int, msgspec.Meta(ge=240, le=8192)] = 1440
    """Image height in pixels."""
    hfov_deg: Annotated[float, msgspec.Meta(ge=30.0, le=100.0)] = 65.0
    """Horizontal field of view of the (pinhole, distortion-free) camera, as a phone's main camera."""
    distance_min_mm: Annotated[float, msgspec.Meta(ge=100.0, le=1000.0)] = 200.0
    """Nearest camera distance from the burn centre."""
    distance_max_mm: Annotated[float, msgspec.Meta(ge=100.0, le=1000.0)] = 400.0
    """Farthest camera distance from the burn centre."""
    area_cm2: Annotated[float, msgspec.Meta(ge=1.0, le=40.0)] = 14.0
    """Burn area: the area of the (cratered) skin surface inside the burn boundary."""
    depth_mm: Annotated[float, msgspec.Meta(ge=0.0, le=8.0)] = 2.0
    """Crater depth at the burn centre, along the inward normal; 0 gives a flat burn."""
    tone: SkinTone = SkinTone.III
    """Skin type of the body part."""
    healing: Annotated[float, msgspec.Meta(ge=0.0, le=1.0)] = 0.0
    """How far the burn's colour has moved toward healed pink (0 fresh, 1 nearly healed)."""
    burn_look: BurnLook = BurnLook.mixed
    """Colour and texture of the burn (training variety; the ground truth does not depend on it)."""
    exif: bool = True
    """Write EXIF FocalLength and FocalLengthIn35mmFilm into the JPEGs, as a phone does."""
    supersample: Annotated[float, msgspec.Meta(ge=1.0, le=3.0)] = 1.5
    """Rays per pixel side for anti-aliasing (1.5 casts 2.25 rays per pixel)."""
    jpeg_quality: Annotated[int, msgspec.Meta(ge=50, le=100)] = 90
    """JPEG quality of the photos."""
    marker_ids: list[Annotated[int, msgspec.Meta(ge=0, le=49)]] | None = None
    """The three DICT_4X4_50 ids printed on the marker strip; None picks three from the seed."""


class PhantomCamera(Frozen, forbid_unknown_fields=False):
    """One view's camera: pinhole, no distortion, x_cam = R @ x_world + t, OpenCV pixel convention."""

    name: str
    """The view's file stem (view_000)."""
    width: int
    """Image width in pixels."""
    height: int
    """Image height in pixels."""
    K: list[list[float]]
    """3x3 intrinsic matrix; the centre of the top-left pixel is (0, 0)."""
    R: list[list[float]]
    """3x3 rotation, world to camera."""
    t: list[float]
    """Translation, world to camera, in mm."""
    hfov_deg: float | None = None
    """Horizontal field of view, degrees (follows from K and width)."""


class PhantomMarker(Frozen, forbid_unknown_fields=False):
    """The printed ArUco strip lying flat beside the body part."""

    dictionary: str
    """OpenCV ArUco dictionary name (DICT_4X4_50)."""
    ids: list[int]
    """Marker ids on the strip, left to right."""
    side_mm: float
    """Side of each marker's black square, in mm."""
    corners_world_mm: dict[str, list[list[float]]]
    """Per id (as text), four world corners in OpenCV ArUco order: top-left, top-right, bottom-right, bottom-left."""
    gap_mm: float | None = None
    """Gap between neighbouring markers on the strip, mm."""
    white_margin_mm: float | None = None
    """White border around the markers, mm."""
    strip_size_mm: list[float] | None = None
    """Length and width of the printed strip, mm."""
    placement: str = ""
    """Where the strip lies, in words."""
    corner_order: str = ""
    """The corner order, in words."""


class PhantomTruth(Frozen, forbid_unknown_fields=False):
    """A phantom scene's ground_truth.json: the fields our evaluation code reads, plus the documentation."""

    format: str
    """burnedge-phantom/1 (the independent generator writes its own name)."""
    generator: str
    """Program and version that rendered the scene."""
    burn_area_cm2: float
    """Area of the displaced (cratered) skin surface inside the burn boundary."""
    reference_area_cm2: float
    """Area of the undisplaced surface inside the burn boundary."""
    burn_perimeter_cm: float
    """Length of the burn boundary on the surface."""
    max_depth_mm: float
    """Largest inward displacement (at the burn centre)."""
    mean_depth_mm: float
    """Area-weighted mean inward displacement over the undisplaced burn surface."""
    volume_cm3: float
    """Volume between the undisplaced and displaced surfaces."""
    burn_centre_world_mm: list[float]
    """Burn centre on the undisplaced surface."""
    burn_normal_world: list[float]
    """Outward unit surface normal at the burn centre."""
    burn_boundary_world_mm: list[list[float]]
    """Points along the burn boundary on the surface, in order."""
    marker: PhantomMarker
    """The scale marker strip."""
    cameras: list[PhantomCamera]
    """One camera per view, in file order."""
    object_to_world: list[list[float]] = msgspec.field(
        default_factory=lambda: [[float(i == j) for j in range(4)] for i in range(4)]
    )
    """4x4 rigid transform from the body part's own frame to the world (identity unless in a series)."""
    units: dict[str, str] = {}
    """Units of every figure."""
    scene: dict[str, Any] = {}
    """The spec rendered and the surface, burn, appearance, lights, drape parameters."""
    definitions: dict[str, str] = {}
    """What each figure means, in words."""
    checks: dict[str, Any] = {}
    """Each figure computed two independent ways, and their relative differences."""
    camera_conventions: dict[str, str] = {}
    """Camera model, extrinsics and pixel conventions, in words."""
