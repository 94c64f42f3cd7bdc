"""Results of the 3D reconstruction stages: each stage's quality record and the analysis report."""

from __future__ import annotations

import enum
from typing import Annotated

import msgspec

from schemas.base import Frozen


class Outcome(enum.StrEnum):
    complete = "complete"
    """Every stage ran; the artifacts are usable (see `scale` for whether they are metric)."""
    failed = "failed"
    """The analysis stopped with a reason a clinician can act on; the inputs are untouched."""


class FailureCode(enum.StrEnum):
    """Why an analysis stopped (machine-readable; the report's `reason` says it in words)."""

    no_pictures = "no_pictures"
    too_few_views = "too_few_views"
    too_few_placed = "too_few_placed"
    """SfM could place too few of the pictures."""
    degenerate_capture = "degenerate_capture"
    """The pictures were taken from (nearly) one spot: no depth can be recovered."""
    no_burn = "no_burn"
    """No burn was found on the reconstructed surface (analysis only)."""
    bad_input = "bad_input"
    """A person's mask or a setting could not be used (analysis only); the reason names it."""
    mixed_scenes = "mixed_scenes"
    """The pictures show more than one scene (or two separate parts the photos do not connect)."""
    no_surface = "no_surface"
    """Stereo found no consistent surface around the burn."""
    bad_ruler = "bad_ruler"
    """The clinician's ruler points could not be placed in 3D."""
    internal_error = "internal_error"
    """A fault in the software, not in the pictures (the report says what it was)."""


class ScaleSource(enum.StrEnum):
    marker = "marker"
    """Printed ArUco marker: corners triangulated from the SfM poses."""
    ruler = "ruler"
    """Two points of known distance marked by the clinician in two or more pictures."""
    none = "none"
    """No scale: sizes are in arbitrary model units and are never reported as mm or cm."""


class SfmQuality(Frozen):
    """Structure-from-Motion quality indicators (the seed's list)."""

    matching: str
    """'exhaustive' (photo set) or 'sequential+loop' (video frames)."""
    images_used: int
    images_registered: int
    unregistered: list[str]
    """Names of pictures SfM could not place."""
    image_pairs_matched: int
    """Pairs with at least one putative SIFT match."""
    image_pairs_verified: int
    """Pairs whose matches passed geometric verification (>= 15 inliers)."""
    mean_matches_per_pair: float
    mean_inlier_ratio: float
    """Verified inliers / putative matches, averaged over matched pairs."""
    mean_reprojection_error_px: float
    median_reprojection_error_px: float
    points: int
    mean_points_per_image: float
    mean_track_length: float
    models_found: int
    """Separate models SfM built; more than one means the pictures did not all connect."""
    focal_px: float
    """Focal length SfM settled on, in pixels of the input pictures."""
    median_triangulation_angle_deg: float
    """Median angle under which the sparse points were seen; near 0 means a capture from one spot."""
    thorough: bool = False
    """True when the fast settings placed too few pictures and the slower, thorough second attempt was used."""


class ScaleEstimate(Frozen):
    """How model units become millimetres, with the evidence."""

    source: ScaleSource
    mm_per_unit: float | None = None
    """Multiply model lengths by this for mm; None when the scale is unknown."""
    relative_uncertainty: float | None = None
    """Robust spread of the per-edge estimates divided by sqrt(edges used) (standard error, 1 sigma)."""
    relative_spread: float | None = None
    """Robust spread (1.4826 MAD) of the per-edge estimates relative to their median."""
    edges_used: int = 0
    edges_rejected: int = 0
    marker_ids: list[int] = msgspec.field(default_factory=list)
    views_with_marker: int = 0
    mean_corner_reprojection_px: float | None = None
    """How well the triangulated marker corners fit their detections."""
    note: str = ""
    """Why the scale is what it is, in words."""


class DenseQuality(Frozen):
    """Multi-view stereo and meshing record."""

    method: str
    """'cpu-plane-sweep' here; 'colmap-patch-match' where a CUDA build is present."""
    units: str
    """'mm' when scaled, else 'model units'."""
    roi_centre: list[float]
    roi_radius: float
    views_with_depth: int
    fused_points: int
    mesh_vertices: int
    mesh_faces: int
    mesh_area: float
    """Surface area of the mesh, in units^2 (mm^2 when scaled)."""


class StageTiming(Frozen):
    stage: str
    seconds: float
    resumed: bool = False
    """True when the stage's artifact was already there and the stage was skipped: `seconds` is then the time it
    took when it was made (0 for artifacts made before durations were kept)."""


class ReconstructionReport(Frozen):
    """The analysis outcome: written as report.json in the analysis folder."""

    outcome: Outcome
    reason: str = ""
    """For a clinician: what went wrong and what to do (empty when complete)."""
    failure: FailureCode | None = None
    pictures: list[str] = msgspec.field(default_factory=list)
    sfm: SfmQuality | None = None
    scale: ScaleEstimate | None = None
    dense: DenseQuality | None = None
    artifacts: dict[str, str] = msgspec.field(default_factory=dict)
    """Artifact name -> path relative to the analysis folder."""
    timings: list[StageTiming] = msgspec.field(default_factory=list)
    software: dict[str, str] = msgspec.field(default_factory=dict)
    """Versions of the libraries that made the result (provenance)."""


Pixel = Annotated[list[float], msgspec.Meta(min_length=2, max_length=2)]


class RulerMark(Frozen):
    """Where the clinician clicked the two ruler points in one picture (pixels as stored, origin top-left)."""

    image: str
    """File name of the picture, as in the analysis."""
    a: Pixel
    """[x, y] of the first point."""
    b: Pixel
    """[x, y] of the second point."""


class RulerPoints(Frozen):
    """Scale fallback: two points of known distance marked in two or more pictures."""

    distance_mm: Annotated[float, msgspec.Meta(gt=0, le=2000)]
    """True distance between the two points (e.g. read off a paper ruler laid by the burn)."""
    marks: list[RulerMark] = msgspec.field(default_factory=list)


class ScaleResult(Frozen):
    """What the scale stage writes (scale.json)."""

    estimate: ScaleEstimate
    model_to_output: list[list[float]]
    """4x4 similarity from SfM model coordinates to the output frame: mm with the marker at the origin
    and its plane z = 0 (z towards the cameras) when scaled; the model frame itself when not."""
    marker_corners_model: dict[str, list[list[float]]] = msgspec.field(default_factory=dict)
    """Triangulated marker corners (model units), by marker id, in ArUco corner order."""


class SkippedPicture(Frozen):
    name: str
    reasons: list[str]
    """Quality-gate reasons (e.g. 'blurry') or 'unsupported'."""


class InputSet(Frozen):
    """What the inputs stage collected (inputs.json): the pictures the analysis uses, and those it left out."""

    source: str
    """The folder or video the pictures came from."""
    video: bool
    pictures: list[str]
    """Names under images/ in the analysis folder, in capture order for a video."""
    skipped: list[SkippedPicture] = msgspec.field(default_factory=list)
