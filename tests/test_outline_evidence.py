"""The outline's evidence: the two passes, skin tone, the per-view checks, view agreement, the fairness
intervals, and how they move the confidence."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from processing.analysis import confidence, fusion, outline_checks, outline_evidence, segment_views
from processing.segmentation import fairness, passes, skin_tone
from schemas.analysis import ModelSummary, OutlineEvidence, SegmentationRecord, ViewMask
from schemas.segmentation import FairnessTable, GroupScore, MaskSource, PassSettings


def red_finder(x: np.ndarray) -> np.ndarray:
    """A stand-in network that knows exactly what burn looks like here: red pixels (NCHW in, N H W out)."""
    r, g = x[:, 0], x[:, 1]
    return np.clip((r - g - 0.2) * 4, 0, 1).astype(np.float32)


def skin_picture(size: int = 600, burn_radius: int = 20, centre=(380, 250)) -> tuple[np.ndarray, np.ndarray]:
    rgb = np.full((size, size, 3), (225, 190, 165), np.uint8)  # light skin
    mask = np.zeros((size, size), np.uint8)
    cv2.circle(mask, centre, burn_radius, 1, -1)
    rgb[mask > 0] = (200, 30, 30)
    return rgb, mask.astype(bool)


def test_the_second_pass_looks_closer_at_a_small_burn_and_sharpens_its_edge():
    rgb, truth = skin_picture(burn_radius=12)
    settings = PassSettings(coarse_size=64, fine_size=64, threshold=0.5, fine_pass=True)
    two = passes.segment(red_finder, rgb, None, settings)
    square = two.fine_square
    assert square is not None and square.side < 200  # around the burn, not the whole picture
    assert square.x0 <= 380 - 12 and square.x0 + square.side >= 380 + 12
    one = passes.segment(
        red_finder, rgb, None, PassSettings(coarse_size=64, fine_size=64, threshold=0.5, fine_pass=False)
    )
    assert one.fine_square is None

    def dice(prob):
        found = prob >= 0.5
        return 2 * (found & truth).sum() / (found.sum() + truth.sum())

    assert dice(two.probability) > dice(one.probability) and dice(two.probability) > 0.9


def test_no_second_pass_where_the_burn_fills_the_region_or_there_is_none():
    rgb, _ = skin_picture(size=200, burn_radius=90, centre=(100, 100))
    settings = PassSettings(coarse_size=64, fine_size=64, threshold=0.5)
    assert passes.segment(red_finder, rgb, None, settings).fine_square is None
    blank = np.full((200, 200, 3), 200, np.uint8)
    assert passes.segment(red_finder, blank, None, settings).fine_square is None


def test_rescaling_puts_the_models_threshold_at_one_half():
    p = np.linspace(0, 1, 101, dtype=np.float32)
    q = passes.rescaled(p, 0.35)
    assert np.all(np.diff(q) >= 0) and q[0] == 0 and q[-1] == pytest.approx(1)
    np.testing.assert_array_equal(q >= 0.5, p >= 0.35)
    assert passes.rescaled(p, 0.5) is p


def test_a_burn_past_the_first_square_is_seen_whole_by_the_second_and_not_called_cut_off():
    rgb, truth = skin_picture(size=600, burn_radius=40, centre=(300, 300))
    settings = PassSettings(coarse_size=64, fine_size=96, threshold=0.4, fine_pass=True)
    region = passes.Square(300 - 20, 200, 200)  # the aim was off: the burn's left part is outside the region
    two = passes.segment(red_finder, rgb, region, settings)
    assert two.fine_square is not None and two.fine_square.x0 < region.x0
    rows, cols = two.looked_at()
    assert cols.start == two.fine_square.x0 and rows.stop >= region.y0 + region.side
    prob = passes.rescaled(two.probability, settings.threshold, two.looked_at())
    np.testing.assert_array_equal(prob >= 0.5, two.probability >= settings.threshold)
    found = prob >= 0.5
    assert found[~two.seen()].sum() == 0 and (found & truth).sum() > 0.95 * truth.sum()
    assert not segment_views._edge_touched(found, two.seen())

    only_first = np.zeros_like(found)
    region.cut(only_first)[:] = True
    assert segment_views._edge_touched(found & only_first, only_first)  # cut where the look ends
    corner = np.zeros_like(found)
    corner[:50, :50] = True  # the picture's own edge is not the edge of the look
    assert not segment_views._edge_touched(corner, np.ones_like(found))


@pytest.mark.parametrize(
    ("skin", "group"),
    [((240, 215, 200), "very light"), ((190, 135, 100), "tan"), ((80, 50, 35), "dark")],
)
def test_skin_tone_is_read_from_the_skin_around_the_wound(skin, group):
    rgb = np.full((300, 300, 3), skin, np.uint8)
    rgb[:8] = 255  # a white patch in the picture: what the correction scales to
    mask = np.zeros((300, 300), bool)
    mask[120:180, 120:180] = True
    rgb[mask] = (150, 20, 30)
    ita = skin_tone.ita_degrees(rgb, mask)
    assert ita is not None and skin_tone.category(ita) == group, ita
    assert skin_tone.ita_degrees(rgb, np.zeros_like(mask)) is None
    grey = np.full((300, 300, 3), 128, np.uint8)  # a drape, no skin
    assert skin_tone.ita_degrees(grey, mask) is None


def test_the_view_checks_see_a_hesitant_low_contrast_outline():
    rgb, truth = skin_picture(burn_radius=60)
    sharp = np.where(truth, 0.95, 0.02).astype(np.float32)
    soft = cv2.GaussianBlur(sharp, (0, 0), 12)
    settings = dict(threshold=0.5, box=None, model_side=192)
    clear = outline_checks.view_checks(rgb, passes.TwoPass(sharp, sharp, None), **settings)
    hesitant = outline_checks.view_checks(rgb, passes.TwoPass(soft, soft, None), **settings)
    assert hesitant["uncertain_band_px"] > 3 * clear["uncertain_band_px"]
    assert clear["outline_contrast"] > 30 and clear["pass_disagreement"] is None
    faint = rgb.copy()
    faint[truth] = (215, 180, 160)  # the burn barely differs from the skin
    assert outline_checks.view_checks(faint, passes.TwoPass(sharp, sharp, None), **settings)["outline_contrast"] < 8
    half = sharp.copy()
    half[:, 380:] = 0.02  # the first pass found half the burn, the closer look all of it
    square = passes.Square(250, 120, 260)
    two = passes.TwoPass(sharp, half, square)
    assert outline_checks.pass_disagreement(two, 0.5) > 0.3


def test_views_that_agree_on_the_surface_score_higher_than_views_that_do_not():
    seen = np.ones((3, 1000))
    same = np.zeros((3, 1000))
    same[:, :200] = 0.9
    assert fusion.view_agreement(same, seen, np.ones(1000, bool)) == 1.0
    split = same.copy()
    split[1, :100] = 0.1  # one view sees half the burn
    assert fusion.view_agreement(split, seen, np.ones(1000, bool)) == pytest.approx((0.5 + 0.5 + 1) / 3, abs=1e-3)
    assert fusion.view_agreement(np.zeros((3, 1000)), seen, np.ones(1000, bool)) is None


def test_fairness_intervals_are_pooled_by_image_and_absent_for_tiny_groups():
    rng = np.random.default_rng(0)
    parts = [(40.0, 100.0), (90.0, 100.0), (10.0, 100.0), (60.0, 100.0), (50.0, 100.0), (70.0, 100.0)]
    score = fairness.group_score("tan", parts, 2000, rng, ita=[12.0, 20.0])
    assert score.dice_pooled == pytest.approx(2 * 320 / 600, abs=1e-4) and score.ita_median == 16.0
    assert score.ci95_low < score.dice_pooled < score.ci95_high
    few = fairness.group_score("dark", parts[:3], 2000, rng)
    assert few.dice_pooled is not None and few.ci95_low is None and few.ci95_high is None
    assert fairness.group_score("light", [], 100, rng).dice_pooled is None


def evidence(**changes) -> OutlineEvidence:
    good = dict(
        view_agreement=0.9,
        pass_disagreement=0.05,
        uncertain_band_px=1.2,
        outline_contrast=25.0,
        skin_tone_ita=20.0,
        skin_tone_group="tan",
        group_dice=0.8,
        group_dice_ci95=[0.74, 0.85],
        group_images=40,
        model_version="burnseg-test",
    )
    return OutlineEvidence(**(good | changes))


GOOD_CAPTURE = dict(
    views_used=12,
    views_seeing_burn=10,
    inlier_ratio=0.8,
    reprojection_px=0.5,
    seen3=1.0,
    scale_uncertainty_percent=0.3,
    clinician_masks=0,
)


@pytest.mark.parametrize(
    ("weak", "words"),
    [
        ({"view_agreement": 0.5}, "photos disagree"),
        ({"pass_disagreement": 0.4}, "closer looks"),
        ({"uncertain_band_px": 6.0}, "hesitates"),
        ({"outline_contrast": 3.0}, "hard to see"),
        ({"group_dice": 0.55}, "less well"),
        ({"group_dice_ci95": None, "group_images": 3}, "tested on few photos"),
    ],
)
def test_a_doubtful_outline_lowers_the_confidence_below_high_with_its_reason(weak, words):
    good = confidence.score(**GOOD_CAPTURE, outline=evidence())
    assert good.level == "high" and good.reasons == [] and good.outline == evidence()
    worse = confidence.score(**GOOD_CAPTURE, outline=evidence(**weak))
    assert worse.score < good.score and any(words in r for r in worse.reasons), worse.reasons
    if "group_images" not in weak:
        assert worse.level != "high"


def test_the_evidence_takes_the_median_of_the_models_views_and_the_groups_held_out_dice():
    table = FairnessTable(
        method="test",
        real_by_ita=[GroupScore(group="tan", images=30, dice_pooled=0.77, ci95_low=0.7, ci95_high=0.83)],
        synthetic_by_fitzpatrick=[],
        photos_without_skin_estimate=0,
    )

    def view(i, source=MaskSource.model, **kw):
        return ViewMask(image=f"v{i}.jpg", source=source, burn_pixels=100, mask=f"masks/v{i}.png", **kw)

    record = SegmentationRecord(
        views=[
            view(0, skin_ita=15.0, pass_disagreement=0.1, outline_contrast=20.0),
            view(1, skin_ita=20.0, pass_disagreement=0.3, outline_contrast=30.0),
            view(2, skin_ita=25.0, uncertain_band_px=2.0),
            view(3, MaskSource.clinician_mask, skin_ita=-60.0),
        ],
        model=ModelSummary(
            version="burnseg-x", sha256="0" * 64, threshold=0.4, fairness=table, architecture="U-Net on Lite0"
        ),
    )
    e = outline_evidence.gather(record, view_agreement=0.8)
    assert e.model_version == "burnseg-x" and e.model_architecture == "U-Net on Lite0"
    assert e.skin_tone_ita == 20.0 and e.skin_tone_group == "tan" and e.group_dice == 0.77
    assert e.group_dice_ci95 == [0.7, 0.83] and e.pass_disagreement == 0.2 and e.uncertain_band_px == 2.0
    people_only = SegmentationRecord(views=[view(0, MaskSource.clinician_outline)])
    assert outline_evidence.gather(people_only, 0.9) is None


def test_an_outline_cut_at_the_edge_of_a_view_is_never_high_confidence_and_says_why():
    good = confidence.score(**GOOD_CAPTURE, outline=evidence())
    cut = confidence.score(**GOOD_CAPTURE, outline=evidence(), outline_cut_views=2)
    assert good.level == "high" and cut.level != "high" and cut.score < good.score
    assert any("reaches the edge of what it looked at in 2 photos" in r for r in cut.reasons)


def test_the_reports_model_row_names_the_model_its_network_and_its_held_out_dice_on_this_skin_tone():
    from processing.report.sections_analysis import _outline_source

    arch = "U-Net decoder on EfficientNet-Lite0 pretrained on ImageNet"
    words = _outline_source(confidence.score(**GOOD_CAPTURE, outline=evidence(model_architecture=arch)))
    assert words.startswith(f"segmentation model burnseg-test ({arch}); skin around the burn estimated tan")
    assert "held-out Dice on real wound photos of this tone 0.80 (40 photos, 95 % CI 0.74–0.85)" in words
    older = _outline_source(confidence.score(**GOOD_CAPTURE, outline=evidence()))
    assert older.startswith("segmentation model burnseg-test; skin")


@pytest.mark.parametrize(("area", "photos", "high"), [(3.0, 6, False), (7.9, 7, False), (3.0, 8, True), (8.5, 6, True)])
def test_a_small_burn_outlined_by_the_model_in_few_photos_is_never_high(area, photos, high):
    capture = GOOD_CAPTURE | {"views_seeing_burn": photos}
    conf = confidence.score(**capture, outline=evidence(), area_cm2=area)
    assert (conf.level == "high") is high
    said = any("small burn" in r and f"{photos} photos" in r for r in conf.reasons)
    assert said is not high
    # a person's outline on every photo: the geometry alone holds for small burns in 6 photos
    assert confidence.score(**capture, outline=None, area_cm2=area).level == "high"
