"""The segmentation model's data, scores and training recipe (training itself only where torch is installed)."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from processing.segmentation import datasets
from processing.segmentation.infer import SHIPPED_MODEL, BurnSegmenter
from processing.segmentation.scores import dice_iou, split_scores
from schemas.segmentation import TrainingConfig
from tests.conftest import SHARED

FUSEG = SHARED / "datasets" / "fuseg2021-train"


def test_dice_and_iou_by_hand():
    a = np.zeros((10, 10), bool)
    b = np.zeros((10, 10), bool)
    a[:, :5], b[:, 3:8] = True, True  # 50 and 50 pixels, 20 shared
    assert dice_iou(a, b) == pytest.approx((40 / 100, 20 / 80))
    assert dice_iou(np.zeros_like(a), np.zeros_like(a)) == (1.0, 1.0)  # no burn, none found
    assert dice_iou(a, np.zeros_like(a)) == (0.0, 0.0)
    pooled = split_scores([(a, b), (a, a)])
    assert pooled.images == 2 and pooled.dice_pooled == pytest.approx((40 + 100) / 200, abs=1e-4)
    assert pooled.dice_mean == pytest.approx((0.4 + 1.0) / 2, abs=1e-4)


def test_the_validation_split_is_fixed_by_name():
    names = [f"{i:04d}.jpg" for i in range(2000)]
    held = [n for n in names if datasets.is_validation(n, 15)]
    assert 0.12 < len(held) / len(names) < 0.18
    # Pinned: a change to the hash or the rule would move photos between training and validation.
    assert held[:5] == ["0004.jpg", "0010.jpg", "0014.jpg", "0021.jpg", "0037.jpg"]


@pytest.mark.skipif(not FUSEG.exists(), reason="needs ../shared/datasets/fuseg2021-train")
def test_the_real_photos_split_into_train_and_held_out_without_overlap():
    train, val = datasets.real_samples(FUSEG, 15)
    assert len(train) + len(val) == 810 and 90 < len(val) < 150
    assert not {s.name for s in train} & {s.name for s in val}
    assert all(s.mask.dtype == np.uint8 and set(np.unique(s.mask)) <= {0, 1} for s in val[:5])


def test_training_scenes_cover_every_skin_type_and_burn_look():
    conf = TrainingConfig()
    specs = [datasets.phantom_spec(i, conf) for i in range(conf.synthetic_scenes)]
    assert {s.tone for s in specs} == set(datasets.TONES) and {s.burn_look for s in specs} == set(datasets.LOOKS)
    held = [s for i, s in enumerate(specs) if i % 5 == 0]
    assert {s.tone for s in held} == set(datasets.TONES)  # scores per skin type on scenes never trained on
    assert datasets.phantom_spec(7, conf) == specs[7]


def test_the_shipped_model_is_small_and_says_what_it_is():
    assert SHIPPED_MODEL.stat().st_size <= 25 * 2**20
    segmenter = BurnSegmenter(SHIPPED_MODEL)
    meta = segmenter.session.get_modelmeta().custom_metadata_map
    assert segmenter.input_size % 16 == 0 and "CC BY-NC" in meta["license"] and meta["card"].endswith(".md")
    report = json.loads((SHIPPED_MODEL.parent / "training_report.json").read_text())
    assert report["model_file"] == SHIPPED_MODEL.name and set(report["synthetic_by_tone"]) == set(
        "I II III IV V VI".split()
    )


def test_a_tiny_training_run_exports_a_model_onnxruntime_can_run(tmp_path: Path):
    pytest.importorskip("torch", reason="training needs the train extra (pip install -e '.[train]')")
    pytest.importorskip("onnx", reason="training needs the train extra (pip install -e '.[train]')")
    from processing.segmentation.train import run

    data = tmp_path / "data"
    (data / "images").mkdir(parents=True)
    (data / "masks").mkdir()
    rng = np.random.default_rng(0)
    for i in range(12):
        image = rng.integers(0, 255, (96, 96, 3), np.uint8)
        mask = np.zeros((96, 96), np.uint8)
        cv2.circle(mask, (48, 48), 20 + i, 255, -1)
        image[mask > 0] = (200, 40, 40)
        cv2.imwrite(str(data / "images" / f"{i:03d}.jpg"), image)
        cv2.imwrite(str(data / "masks" / f"{i:03d}.png"), mask)
    conf = TrainingConfig(
        input_size=64,
        widths=[4, 8, 8, 8, 8],
        epochs=1,
        synthetic_scenes=0,
        synthetic_per_epoch=0,
        batch_size=4,
        validation_percent=25,
        threads=1,
    )
    report = json.loads(run(conf, data, tmp_path / "out", tmp_path / "cache").read_text())
    assert report["epochs_run"] == 1 and report["real_validation"]["images"] >= 1
    prob = BurnSegmenter(tmp_path / "out" / report["model_file"]).probability(np.zeros((50, 70, 3), np.uint8))
    assert prob.shape == (50, 70) and 0 <= prob.min() <= prob.max() <= 1
