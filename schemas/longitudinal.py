"""Healing over time (track.json): each visit's burn against the first measured one, the healing rate, and
prompts for clinical review.

Decision support only: the figures describe the surfaces in the photos; the prompts name a published rule
and ask a clinician to look, they never decide care.
"""

from __future__ import annotations

import msgspec

from schemas.base import Frozen

TRACK_DISCLAIMER = (
    "Decision support, not a diagnosis: areas and changes describe the burn surface in the photos of each visit. "
    "Review prompts quote published rules of thumb from other wound populations; a clinician examines the "
    "wound and decides on care."
)

TRACK_UNITS = {
    "day": "days since the injury (or since the first visit when the injury day is unknown)",
    "area": "cm2",
    "perimeter": "cm",
    "relief": "mm",
    "volume": "cm3",
    "registration": "mm, in the first measured visit's frame",
    "healing_rate": "cm2 per day; positive = the burn is shrinking",
}


class Registration(Frozen):
    """How a visit's surface was laid onto the first measured visit's (the baseline's) surface."""

    method: str
    """What was run, e.g. 'fpfh_ransac+icp_point_to_plane' (coarse global alignment, then refinement)."""
    transform_to_baseline: list[list[float]]
    """4x4 rigid transform (rows) taking points of this visit's frame (mm) into the baseline's frame (mm)."""
    rmse_mm: float
    """Root mean square distance (mm) from this visit's healthy skin to the baseline's surface (along its normals)
    over the points matched within the last ICP distance, after registration. It holds the reconstruction noise
    of both visits (about 0.1 mm each on the phantoms): it is not the registration error."""
    overlap: float
    """Share (0..1) of this visit's healthy-skin points that found a baseline point within the last ICP
    distance: how much of the skin the two surfaces share."""
    points: int
    """Healthy-skin points of this visit used by the refinement."""
    baseline_points: int
    """Healthy-skin points of the baseline used by the refinement."""
    ransac_tries: int
    """Independent RANSAC tries that were run."""
    ransac_agreeing: int
    """Tries whose refined alignment agrees (within 1 mm RMS on the skin) with the one kept."""
    burn_shift_mm: float
    """Distance (mm) between the burn's centre of this visit, carried into the baseline's frame, and the baseline
    burn's centre: burns contract towards their centre, so a large shift hints at a wrong alignment."""
    seconds: float
    """Time the registration took (0 when read from the cache)."""
    texture_agreement: float | None = None
    """Correlation (-1..1) of the skin's fine texture (grey level minus its local mean) between matched points:
    near 0 when the alignment is wrong even if the shapes fit; None when the meshes carry no colours."""
    warning: str = ""
    """Why the alignment may be wrong (poor fit, little overlap, ambiguous RANSAC, burn moved); empty when none."""


class TrackSession(Frozen):
    """One visit, its figures and its change against the baseline."""

    day: float
    """Day of the visit (days since the injury; see `units`)."""
    label: str
    """Name of the visit (e.g. the session folder)."""
    analysis: str
    """The visit's analysis folder (`burnedge track`); from the gateway's API, its link (/api/v1/analyses/{id})."""
    status: str
    """The analysis status: 'ok', 'unscaled', 'failed', or 'missing' (no analysis.json)."""
    baseline: bool = False
    """This visit is the baseline: the first visit with a result in real units."""
    reason: str = ""
    """Why this visit has no figures or no change (failed, unscaled, missing); empty otherwise."""
    area_cm2: float | None = None
    """Burn surface area (cm2)."""
    perimeter_cm: float | None = None
    """Length of the burn edge on the surface (cm)."""
    relief_max_mm: float | None = None
    """Deepest point below the healthy-skin reference (mm; positive = sunken). Geometry, not burn depth."""
    volume_cm3: float | None = None
    """Volume between the reference surface and the sunken burn (cm3): a proxy."""
    confidence_level: str | None = None
    """The analysis confidence level: 'high', 'moderate' or 'low'."""
    registration_rmse_mm: float | None = None
    """RMSE (mm) of the registration to the baseline on healthy skin; 0 for the baseline; None when not
    registered."""
    registration_overlap: float | None = None
    """Share (0..1) of healthy skin matched on the baseline; 1 for the baseline; None when not registered."""
    registration_warning: str = ""
    """Why the registration may be wrong, or why it was not done; empty when it is sound."""
    area_change_cm2: float | None = None
    """A_t - A_0 (cm2): negative = smaller than at the baseline."""
    area_change_percent: float | None = None
    """100 (A_t - A_0) / A_0 (%): negative = smaller than at the baseline."""
    percent_area_reduction: float | None = None
    """100 (A_0 - A_t) / A_0 (%), the wound-care literature's figure: positive = smaller."""
    relief_change_mm: float | None = None
    """relief_max_t - relief_max_0 (mm): negative = shallower."""
    volume_change_cm3: float | None = None
    """V_t - V_0 (cm3): negative = less sunken volume."""
    transform_to_baseline: list[list[float]] | None = None
    """4x4 rigid transform from this visit's frame to the baseline's (identity for the baseline)."""


class StallFlag(Frozen):
    """A published rule applied to the series: a prompt for clinical review, never a decision."""

    rule: str
    """The rule in words, with its threshold."""
    citation: str
    """Where the rule comes from, and the population it was found in."""
    evaluable: bool
    """Whether the series holds what the rule needs (e.g. a visit at 4 weeks or later)."""
    triggered: bool
    """The rule's condition holds (always false when not evaluable)."""
    detail: str
    """The figures behind the verdict, or what is missing ('not yet evaluable: ...')."""


class TrackResult(Frozen):
    """track.json: the healing of one burn over the visits."""

    sessions: list[TrackSession]
    """Every visit in the order given, failed ones included."""
    healing_rate_cm2_per_day: float | None = None
    """-slope (cm2/day) of the least-squares line of area against day over every measured visit: positive = the
    burn shrinks. None with fewer than two measured visits on different days."""
    healing_rate_se_cm2_per_day: float | None = None
    """Standard error of that slope (cm2/day); None with fewer than three measured visits."""
    projected_closure_day: float | None = None
    """Day on which the fitted line reaches zero area (an extrapolation, not a prediction of epithelialisation).
    None when the burn is not shrinking or fewer than three visits were measured; `projection_note` says why."""
    projected_closure_range_days: list[float | None] | None = None
    """[earliest, latest] day of the 95 % interval of that crossing (Fieller's interval, Student t with n - 2
    degrees of freedom); latest is None when the data cannot exclude that the burn stops shrinking."""
    projection_note: str = ""
    """Why no projection is given, or what limits it."""
    stall_flags: list[StallFlag] = msgspec.field(default_factory=list)
    """Review prompts from published rules, each with its citation and whether it can be judged yet."""
    notes: list[str] = msgspec.field(default_factory=list)
    """What else the reader should know (visits left out and why)."""
    disclaimer: str = TRACK_DISCLAIMER
    units: dict[str, str] = msgspec.field(default_factory=lambda: dict(TRACK_UNITS))
    """The unit of every kind of figure above."""
