"""The burn analysis result (analysis.json): metrics with units in their names, confidence, provenance.

Decision support only: the figures describe the surface the photos show; burn depth as a clinical
category (superficial, partial, full thickness) stays the clinician's call and is never derived here.
"""

from __future__ import annotations

import enum

import msgspec

from schemas.base import Frozen
from schemas.reconstruction import FailureCode
from schemas.segmentation import FairnessTable, MaskSource

DISCLAIMER = (
    "Decision support, not a diagnosis: measurements of the surface the photos show. Surface relief is "
    "geometry, not the clinical burn depth, which needs examination over time."
)


class AnalysisStatus(enum.StrEnum):
    ok = "ok"
    """Measured in real units (mm, cm2)."""
    unscaled = "unscaled"
    """The surface and the burn were found, but nothing gave the scale: no figure in mm or cm is reported."""
    failed = "failed"
    """No measurement; `reason` says why and what to do."""


class BurnMetrics(Frozen):
    """The burn on the reconstructed surface; every length/area/volume is None when the scale is unknown."""

    area_cm2: float | None = None
    """Surface area of the burn (faces split along the fused 0.5 probability level)."""
    perimeter_cm: float | None = None
    """Length of the burn edge on the surface, smoothed over `perimeter_smoothing_mm`."""
    relief_max_mm: float | None = None
    """Deepest point below the reference surface fitted to the healthy skin around the burn (positive = sunken)."""
    relief_mean_mm: float | None = None
    """Area-weighted mean of that relief over the burn."""
    raised_max_mm: float | None = None
    """Highest point above the reference surface (blisters, swelling); positive = raised."""
    volume_cm3: float | None = None
    """Volume between the reference surface and the sunken burn surface (a proxy, not tissue loss)."""
    tbsa_percent: float | None = None
    """This burn's area as a share of the patient's body surface area (Mosteller), when height and weight are known."""
    area_model_units2: float | None = None
    """The area in the reconstruction's own units, for comparing unscaled analyses of the same capture only."""
    burn_loops: int = 0
    """Separate pieces of burn edge found (1 for a single burn without islands)."""


class OutlineEvidence(Frozen):
    """The raw indicators of how far the model's outline can be trusted (processing/analysis/outline_checks.py)."""

    view_agreement: float | None = None
    """Mean IoU, on the surface, between the burns two views see where both look (1: every view agrees)."""
    pass_disagreement: float | None = None
    """Median over the model's views of 1 - Dice between its first pass and its final mask."""
    uncertain_band_px: float | None = None
    """Median width, in model pixels, of the band along the outline where the model hesitates."""
    outline_contrast: float | None = None
    """Median CIELAB Delta E across the outline."""
    skin_tone_ita: float | None = None
    """Median estimated ITA (degrees) of the skin around the burn over the views."""
    skin_tone_group: str | None = None
    """The ITA category of that estimate (very light, light, intermediate, tan, brown, dark)."""
    group_dice: float | None = None
    """The model's held-out pooled Dice on real photos of that skin tone group."""
    group_dice_ci95: list[float] | None = None
    """Its bootstrap 95 % interval [low, high]; None with too few held-out photos to tell."""
    group_images: int = 0
    """Held-out photos in that group."""
    model_version: str = ""
    """The segmentation model behind the masks ('' when people drew them all)."""
    model_architecture: str = ""
    """Its network in words, e.g. "U-Net decoder on EfficientNet-Lite0 pretrained on ImageNet" ('' for a model
    made before it was stamped)."""


class ConfidenceRecord(Frozen):
    """The raw indicators and the score made from them (weights in docs/analysis.md)."""

    score: float
    """C = 1 / (1 + exp(-z)), z a weighted sum of the indicators below; 0..1."""
    level: str
    """'high' (C >= 0.8), 'moderate' (>= 0.5) or 'low'."""
    reasons: list[str] = msgspec.field(default_factory=list)
    """Plain-language reasons the confidence is not high, each with what to do."""
    views_used: int = 0
    """Pictures placed by SfM."""
    views_seeing_burn: int = 0
    """Pictures that see some of the burn surface."""
    inlier_ratio: float | None = None
    """Mean share of feature matches that fit the geometry (SfM)."""
    reprojection_error_px: float | None = None
    """Median SfM reprojection error."""
    burn_seen_by_3_fraction: float | None = None
    """Share of the burn area seen by at least three pictures."""
    scale_uncertainty_percent: float | None = None
    """1-sigma relative uncertainty of the scale, in percent."""
    clinician_masks: int = 0
    """Views whose mask a person provided instead of the model."""
    outline: OutlineEvidence | None = None
    """How sure the model's outline is, and how the model does on this skin tone; None when people drew
    every mask."""


class ScaleSummary(Frozen):
    method: str
    """'marker', 'ruler' or 'none'."""
    mm_per_unit: float | None = None
    uncertainty_percent: float | None = None


class ViewMask(Frozen):
    """The burn mask used for one picture and where it came from."""

    image: str
    source: MaskSource
    burn_pixels: int
    mask: str
    """Path relative to the analysis folder: PNG, 255 = burn."""
    probability: str = ""
    """8-bit PNG of the model's probability (empty for a person's mask)."""
    overlay: str = ""
    crop: list[int] | None = None
    """[x0, y0, side] of the square the model looked at first (pixels as stored); None: the whole picture or a
    person's mask. Outside it and fine_square the view says nothing (it is not counted as healthy skin)."""
    burn_at_crop_edge: bool = False
    """The model's burn touches the edge of what it looked at (crop and fine_square together): the burn may
    continue beyond it."""
    fine_square: list[int] | None = None
    """[x0, y0, side] of the model's second, closer look around the burn; None when it did not run."""
    pass_disagreement: float | None = None
    """1 - Dice between the model's first pass and its final mask (processing/analysis/outline_checks.py)."""
    uncertain_band_px: float | None = None
    """Mean width, in model pixels, of the band along the outline where the model hesitates."""
    outline_contrast: float | None = None
    """CIELAB Delta E between just inside and just outside the outline; low: burn and skin look alike."""
    skin_ita: float | None = None
    """Estimated ITA (degrees) of the healthy skin around the burn; None where too little skin shows."""


class ModelSummary(Frozen):
    """Which segmentation model drew the masks, how it ran, and how it scores by skin tone."""

    version: str
    """From the model file's metadata ('' for a model made before versions were stamped)."""
    sha256: str
    threshold: float
    """Probability the model cuts at; the probability maps are rescaled so it sits at 0.5."""
    fairness: FairnessTable | None = None
    """Held-out Dice by skin tone, from the model file (docs/segmentation-model.md)."""
    architecture: str = ""
    """The network in words, from the model file's metadata ('' for a model made before it was stamped)."""


class SegmentationRecord(Frozen):
    """segmentation/segmentation.json: every placed picture's mask, and the person's masks that matched none."""

    views: list[ViewMask]
    unmatched_masks: list[str] = msgspec.field(default_factory=list)
    """Files in --masks named after no placed picture (a typo, or a picture SfM could not place): not used."""
    model: ModelSummary | None = None
    """The segmentation model that drew the masks; None when people drew every one."""


class ReferenceRecord(Frozen):
    """The healthy-skin reference surface that surface relief is measured from."""

    kind: str
    """'ridged', 'quartic', 'quadratic' or 'plane' (see docs/analysis.md for when each is used)."""
    ring_points: int
    ring_rms_mm: float | None = None
    """How far the healthy ring departs from the fitted reference (RMS), in mm when scaled."""
    holdout_mm: float | None = None
    """Median error of the reference predicting ring skin it was not fitted to (each eighth of the ring from the
    rest), in mm when scaled: how well it can stand in for the skin under the burn. None when the ring is too
    small to test (under 600 points on a 0.7 mm grid); the uncertainty note then looks at ring_rms_mm."""


class AnalysisResult(Frozen):
    """analysis.json: what `burnedge analyze` and the gateway report."""

    status: AnalysisStatus
    reason: str | None = None
    failure: FailureCode | None = None
    metrics: BurnMetrics = msgspec.field(default_factory=BurnMetrics)
    confidence: ConfidenceRecord | None = None
    scale: ScaleSummary | None = None
    timings_s: dict[str, float] = msgspec.field(default_factory=dict)
    """Seconds per stage; for a stage in reused_stages, the time it took when it was made."""
    reused_stages: list[str] = msgspec.field(default_factory=list)
    """Stages an earlier try or run had finished, reused as they were (a retry resumes after a crash)."""
    hours_since_injury: float | None = None
    provisional: bool | None = None
    """True when the photos were taken less than 72 h after the injury (burns evolve: re-measure later); None when
    the time since injury is unknown, which a reader must treat as possibly provisional."""
    notes: list[str] = msgspec.field(default_factory=list)
    """What else the reader should know: masks that matched no picture, a burn cut off at the model's view,
    why relief is missing."""
    views: list[ViewMask] = msgspec.field(default_factory=list)
    fusion_rule: str = ""
    reference: ReferenceRecord | None = None
    artifacts: dict[str, str] = msgspec.field(default_factory=dict)
    """Artifact name -> path relative to the analysis folder (painted mesh, masks, overlays, COLMAP model)."""
    software: dict[str, str] = msgspec.field(default_factory=dict)
    disclaimer: str = DISCLAIMER
