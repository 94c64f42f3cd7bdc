"""The outline's evidence for the confidence: the views' indicators summed up, and what the model's held-out
scores say about the skin tone in these photos. The weights that turn it into the score are hand-set
(see processing/analysis/confidence.py and docs/analysis.md) and checked on rendered phantoms.
"""

from __future__ import annotations

import numpy as np

from processing.segmentation import skin_tone
from schemas.analysis import OutlineEvidence, SegmentationRecord
from schemas.segmentation import MaskSource

AGREEMENT_OK = 0.75
"""Views whose burns overlap less than this on the surface (mean IoU) disagree on the outline."""
B_AGREEMENT = 10.0
PASS_OK = 0.15
"""A final mask more than this far (1 - Dice) from the first pass's: the closer look changed a lot."""
B_PASS = 8.0
BAND_OK_PX = 2.5
"""A hesitant band along the outline wider than this, in model pixels."""
B_BAND = 0.8
CONTRAST_OK = 8.0
"""Delta E across the outline below this: burn and skin look alike there."""
B_CONTRAST = 0.4
GROUP_DICE_OK = 0.7
"""Held-out Dice of the skin tone group below this lowers the confidence."""
GROUP_CI_WIDE = 0.25
"""A 95 % interval wider than this (or none: too few photos) says the group's accuracy is not known."""
B_GROUP_LOW = 1.5
B_GROUP_UNKNOWN = 0.5


def _median(values: list[float | None]) -> float | None:
    known = [v for v in values if v is not None]
    return round(float(np.median(known)), 3) if known else None


def gather(segmentation: SegmentationRecord, view_agreement: float | None) -> OutlineEvidence | None:
    """The evidence of a finished segmentation; None when people drew every mask."""
    views = [v for v in segmentation.views if v.source is MaskSource.model]
    model = segmentation.model
    if not views or model is None:
        return None
    ita = _median([v.skin_ita for v in views])
    group = skin_tone.category(ita) if ita is not None else None
    row = None
    if group is not None and model.fairness is not None:
        row = next((g for g in model.fairness.real_by_ita if g.group == group), None)
    return OutlineEvidence(
        view_agreement=view_agreement,
        pass_disagreement=_median([v.pass_disagreement for v in views]),
        uncertain_band_px=_median([v.uncertain_band_px for v in views]),
        outline_contrast=_median([v.outline_contrast for v in views]),
        skin_tone_ita=None if ita is None else round(ita, 1),
        skin_tone_group=group,
        group_dice=row.dice_pooled if row else None,
        group_dice_ci95=[row.ci95_low, row.ci95_high] if row and row.ci95_low is not None else None,
        group_images=row.images if row else 0,
        model_version=model.version,
        model_architecture=model.architecture,
    )


def terms(e: OutlineEvidence) -> tuple[dict[str, float], list[str]]:
    """The penalties (negative z terms) and the plain reasons, each with what to do."""
    out: dict[str, float] = {}
    reasons = []
    check = "check the overlays, and draw the burn's outline on a few photos (--masks) if it is wrong"
    if e.view_agreement is not None and e.view_agreement < AGREEMENT_OK:
        out["agreement"] = -B_AGREEMENT * (AGREEMENT_OK - e.view_agreement)
        reasons.append(f"the photos disagree on where the burn ends (they overlap {e.view_agreement:.0%}): {check}")
    if e.pass_disagreement is not None and e.pass_disagreement > PASS_OK:
        out["passes"] = -B_PASS * (e.pass_disagreement - PASS_OK)
        reasons.append(
            f"the model's first and closer looks outline the burn differently ({e.pass_disagreement:.0%}): {check}"
        )
    if e.uncertain_band_px is not None and e.uncertain_band_px > BAND_OK_PX:
        out["band"] = -B_BAND * (e.uncertain_band_px - BAND_OK_PX)
        reasons.append(f"the model hesitates along the outline: {check}")
    if e.outline_contrast is not None and e.outline_contrast < CONTRAST_OK:
        out["contrast"] = -B_CONTRAST * (CONTRAST_OK - e.outline_contrast)
        reasons.append(
            f"the burn's edge differs little in colour from the skin around it (Delta E {e.outline_contrast:.0f}), "
            f"so it is hard to see: {check}"
        )
    if e.skin_tone_group is not None and e.model_version:
        wide = e.group_dice_ci95 is None or e.group_dice_ci95[1] - e.group_dice_ci95[0] > GROUP_CI_WIDE
        if e.group_dice is not None and e.group_dice < GROUP_DICE_OK:
            out["group"] = -B_GROUP_LOW
            reasons.append(
                f"the model outlines wounds on {e.skin_tone_group} skin less well (held-out Dice "
                f"{e.group_dice:.2f} on {e.group_images} photos): {check}"
            )
        elif wide:
            out["group"] = -B_GROUP_UNKNOWN
            reasons.append(
                f"the model was tested on few photos of {e.skin_tone_group} skin ({e.group_images}), so its "
                f"accuracy there is not well known: {check}"
            )
    return out, reasons
