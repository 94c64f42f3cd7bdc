"""How far to trust a burn measurement: the raw indicators, a logistic score, and reasons in words.

    z = B0 + B_SEEN * seen3 + B_INLIER * inlier_ratio + B_REPROJ * reprojection_px
          + B_SCALE * scale_uncertainty_percent + B_VIEWS * min(views_seeing_burn, 10) / 10
          - UNSCALED_PENALTY (no scale) - CUT_OFF_PENALTY (the burn may continue beyond the surface)
          + the outline's penalties (processing/analysis/outline_evidence.py: views disagreeing on the
            surface, the model's two passes disagreeing, a hesitant or low-contrast edge, a skin tone
            the model is weak or little tested on)
    C = 1 / (1 + exp(-z))

The weights are set by hand, not fitted (there is no labelled set of trusted and untrusted burn
measurements to fit them to). With every indicator at a good capture's value (seen3 1.0, inlier
ratio 0.8, 0.5 px, 0.3 % scale, 10 views) C = 0.94. Each of these alone brings C below 0.5 (low):
a burn seen by three or more pictures over only half its area, a 2 % scale uncertainty, a 2.5 px
reprojection error, no scale at all. docs/analysis.md lists them with the reasoning.
"""

from __future__ import annotations

import math

from processing.analysis import outline_evidence
from schemas.analysis import ConfidenceRecord, OutlineEvidence
from schemas.base import counted

B0 = -7.5
B_SEEN = 8.0
B_INLIER = 2.0
B_REPROJ = -1.5
B_SCALE = -2.0
B_VIEWS = 2.0
UNSCALED_PENALTY = 5.0
"""An unscaled result is only a shape: subtract this from z."""
CUT_OFF_PENALTY = 2.5
"""The burn reaches the edge of what was reconstructed or looked at: part of it may be missing."""
SMALL_BURN_CM2 = 8.0
"""A burn measured under this area, outlined by the model, needs FEW_VIEWS_FOR_SMALL photos or more to be "high":
small burns (6 cm2 or less) with room for the error this guards against (a 6 cm2 burn measured 6.5)."""
FEW_VIEWS_FOR_SMALL = 8
"""Calibrated on rendered phantoms (issue 42): small burns (2-6 cm2) on a foot or forearm seen in 6 photos came out
up to 9 % off with the model's outline (the geometry alone under 4 %), at scores above 0.93; the same burns in 12
photos within 1 %. On a small burn the outline decides much of the area, and a few photos give it few votes."""


def score(
    views_used: int,
    views_seeing_burn: int,
    inlier_ratio: float,
    reprojection_px: float,
    seen3: float,
    scale_uncertainty_percent: float | None,
    clinician_masks: int,
    *,
    cut_off: bool = False,
    outline_cut_views: int = 0,
    min_views: int = 3,
    outline: OutlineEvidence | None = None,
    area_cm2: float | None = None,
) -> ConfidenceRecord:
    unc = scale_uncertainty_percent
    terms = {
        "seen": B_SEEN * seen3,
        "inlier": B_INLIER * inlier_ratio,
        "reprojection": B_REPROJ * reprojection_px,
        "views": B_VIEWS * min(views_seeing_burn, 10) / 10,
        "scale": B_SCALE * unc if unc is not None else -UNSCALED_PENALTY - B_SCALE * 0.3,
        "cut_off": -CUT_OFF_PENALTY if cut_off else 0.0,
        "outline_cut": -CUT_OFF_PENALTY if outline_cut_views else 0.0,
    }
    outline_terms, outline_reasons = outline_evidence.terms(outline) if outline else ({}, [])
    c = 1.0 / (1.0 + math.exp(-(B0 + sum(terms.values()) + sum(outline_terms.values()))))
    reasons = []
    if unc is None:
        reasons.append("no scale was found: put the printed marker flat beside the burn, in every photo")
    elif unc > 1.0:
        reasons.append(f"the scale is uncertain (±{unc:.1f} %): keep the marker flat, unfolded and sharp in the photos")
    if seen3 < 0.8:
        reasons.append(
            f"only {seen3:.0%} of the burn was seen from {min_views} or more angles: "
            "take more photos walking around the burn"
        )
    if views_seeing_burn < 4:
        reasons.append(f"only {views_seeing_burn} photos show the burn: take at least six from different sides")
    if reprojection_px > 1.2:
        reasons.append(f"the photos fit together loosely ({reprojection_px:.1f} px): some may be blurred")
    if inlier_ratio < 0.3:
        reasons.append("few features matched between photos: avoid glare and keep the burn in focus")
    if cut_off:
        reasons.append(
            "the burn reaches the edge of the reconstructed surface: part of it may be missing; "
            "take photos that show healthy skin all around it"
        )
    if outline_cut_views:
        reasons.append(
            f"the model's outline reaches the edge of what it looked at in {counted(outline_cut_views, 'photo')}: "
            "the burn may be larger than measured"
        )
    reasons += outline_reasons
    small_and_few = (
        outline is not None
        and area_cm2 is not None
        and area_cm2 < SMALL_BURN_CM2
        and views_seeing_burn < FEW_VIEWS_FOR_SMALL
    )
    if small_and_few:
        reasons.append(
            f"a small burn ({area_cm2:.1f} cm²) outlined by the model in only {counted(views_seeing_burn, 'photo')}: "
            f"at this size the outline decides much of the area; take {FEW_VIEWS_FOR_SMALL} or more photos around "
            "it, or check the overlays and draw its outline"
        )
    level = "high" if c >= 0.8 else "moderate" if c >= 0.5 else "low"
    if level == "high" and (cut_off or outline_cut_views or outline_reasons or small_and_few):
        level = "moderate"  # never "high" beside an open doubt about the outline the figures come from
    if level != "high" and not reasons:
        # No single indicator is poor, but together they are: name the weakest against a good capture.
        good = {
            "seen": B_SEEN,
            "inlier": B_INLIER * 0.8,
            "reprojection": B_REPROJ * 0.5,
            "views": B_VIEWS,
            "scale": B_SCALE * 0.3,
        }
        weakest = min(good, key=lambda k: terms[k] - good[k])
        words = {
            "seen": "parts of the burn were seen from too few angles",
            "inlier": "features matched poorly",
            "reprojection": "the photos fit together loosely",
            "views": "few photos show the burn",
            "scale": "the scale is less certain than usual",
        }
        reasons.append(f"several indicators are middling; the weakest: {words[weakest]}. Retake if you can")
    return ConfidenceRecord(
        score=round(c, 3),
        level=level,
        reasons=reasons,
        views_used=views_used,
        views_seeing_burn=views_seeing_burn,
        inlier_ratio=round(inlier_ratio, 3),
        reprojection_error_px=round(reprojection_px, 3),
        burn_seen_by_3_fraction=round(seen3, 3),
        scale_uncertainty_percent=None if unc is None else round(unc, 3),
        clinician_masks=clinician_masks,
        outline=outline,
    )
