"""The burn analysis end to end on a small rendered phantom: real COLMAP, real model, real files, the real CLI."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import cv2
import msgspec
import numpy as np
import pytest
import trimesh

from harness.processes import REPO
from processing.analysis import confidence, segment_views
from processing.analysis.pipeline import Patient
from processing.analysis.pipeline import run as analyze
from processing.segmentation.infer import SHIPPED_MODEL, Box, BurnSegmenter
from schemas.analysis import AnalysisResult, AnalysisStatus
from schemas.config import AnalysisConfig, Config
from schemas.errors import InvalidInput
from schemas.reconstruction import FailureCode
from schemas.segmentation import MaskSource
from tests.phantom_helpers import SMALL, hide_marker, render_small_patch


def cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "burnedge.cli", *args], capture_output=True, text=True, cwd=REPO, timeout=600
    )


@pytest.fixture(scope="module")
def phantom(tmp_path_factory) -> Path:
    return render_small_patch(tmp_path_factory.mktemp("phantom"))


@pytest.fixture(scope="module")
def analysed(phantom, tmp_path_factory) -> tuple[Path, dict]:
    """`burnedge analyze` with the true masks given as a person's masks."""
    out = tmp_path_factory.mktemp("analysis")
    r = cli(
        "analyze",
        str(phantom / "images"),
        "--masks",
        str(phantom / "masks"),
        "--out",
        str(out),
        "--hours-since-injury",
        "30",
        "--height-cm",
        "170",
        "--weight-kg",
        "65",
    )
    assert r.returncode == 0, r.stderr[-3000:]
    return out, json.loads(r.stdout)


def test_true_masks_give_the_phantoms_area_perimeter_and_relief(phantom, analysed):
    out, result = analysed
    truth = json.loads((phantom / "ground_truth.json").read_text())
    assert result["status"] == "ok" and result["reason"] is None
    m = result["metrics"]
    assert m["area_cm2"] == pytest.approx(truth["burn_area_cm2"], rel=0.04)
    assert m["perimeter_cm"] == pytest.approx(truth["burn_perimeter_cm"], rel=0.06)
    assert m["relief_max_mm"] == pytest.approx(truth["max_depth_mm"], abs=0.5)
    assert m["volume_cm3"] == pytest.approx(truth["volume_cm3"], rel=0.3)
    assert m["burn_loops"] == 1
    bsa_cm2 = (170 * 65 / 3600) ** 0.5 * 1e4
    assert m["tbsa_percent"] == pytest.approx(100 * m["area_cm2"] / bsa_cm2, rel=1e-3)
    assert result["scale"]["method"] == "marker" and result["scale"]["uncertainty_percent"] < 1.0
    assert result["provisional"] is True and result["hours_since_injury"] == 30
    assert {"sfm", "dense", "segment", "surface", "metrics"} <= set(result["timings_s"])
    c = result["confidence"]
    assert 0 <= c["score"] <= 1 and c["views_seeing_burn"] >= 6 and c["burn_seen_by_3_fraction"] > 0.9
    assert c["clinician_masks"] == len(result["views"]) == SMALL["views"]
    assert "not the clinical burn depth" in result["disclaimer"]


def test_every_view_keeps_its_mask_overlay_and_the_painted_mesh_opens(analysed):
    out, result = analysed
    for view in result["views"]:
        assert view["source"] == "clinician_mask"
        mask = cv2.imread(str(out / "segmentation" / view["mask"]), cv2.IMREAD_GRAYSCALE)
        assert set(np.unique(mask)) <= {0, 255} and int((mask > 0).sum()) == view["burn_pixels"]
        assert (out / "segmentation" / view["overlay"]).exists()
    mesh = trimesh.load(out / result["artifacts"]["painted_mesh"], force="mesh")
    colours = np.asarray(mesh.visual.vertex_colors)[:, :3].astype(int)
    magenta = (colours[:, 0] > 200) & (colours[:, 1] < 120) & (colours[:, 2] > 150)
    assert 0.01 < magenta.mean() < 0.6  # the burn is painted, the healthy skin is not
    stored = msgspec.json.decode((out / "analysis.json").read_bytes(), type=AnalysisResult)
    assert msgspec.to_builtins(stored) == result


def test_a_second_run_resumes_and_new_masks_rerun_only_the_burn_stages(phantom, analysed, tmp_path):
    out, first = analysed
    again = analyze(Config(), phantom / "images", out, masks=phantom / "masks")
    stages = ("sfm", "dense", "mesh", "segment", "surface", "metrics")
    assert set(stages) <= set(again.reused_stages)  # each reports the time it took when it was made
    assert all(again.timings_s[s] == first["timings_s"][s] > 0 for s in stages)
    eroded = tmp_path / "masks"
    eroded.mkdir()
    for mask in (phantom / "masks").iterdir():
        m = cv2.imread(str(mask), cv2.IMREAD_GRAYSCALE)
        cv2.imwrite(str(eroded / mask.name), cv2.erode(m, np.ones((9, 9), np.uint8)))
    smaller = analyze(Config(), phantom / "images", out, masks=eroded)
    assert "sfm" in smaller.reused_stages and "segment" not in smaller.reused_stages
    assert smaller.timings_s["segment"] > 0
    assert smaller.metrics.area_cm2 < again.metrics.area_cm2


def test_the_model_finds_the_burn_when_no_person_drew_it(phantom, analysed):
    out, _ = analysed
    result = analyze(Config(), phantom / "images", out)
    truth = json.loads((phantom / "ground_truth.json").read_text())
    assert result.status is AnalysisStatus.ok
    assert all(v.source is MaskSource.model and v.probability and v.crop for v in result.views)
    assert result.provisional is None and result.hours_since_injury is None  # unknown timing is not "final"
    assert result.metrics.area_cm2 == pytest.approx(truth["burn_area_cm2"], rel=0.25)


def test_no_burn_on_the_surface_is_a_clear_failure(phantom, analysed, tmp_path):
    out, _ = analysed
    work = tmp_path / "analysis"
    shutil.copytree(out, work)
    empty = tmp_path / "empty"
    empty.mkdir()
    for mask in (phantom / "masks").iterdir():
        cv2.imwrite(str(empty / mask.name), np.zeros((SMALL["height"], SMALL["width"]), np.uint8))
    r = cli("analyze", str(phantom / "images"), "--masks", str(empty), "--out", str(work))
    assert r.returncode == 7
    result = json.loads(r.stdout)
    assert result["status"] == "failed" and result["failure"] == FailureCode.no_burn
    assert "--masks" in result["reason"] and result["metrics"]["area_cm2"] is None


def test_without_a_scale_nothing_is_reported_in_mm_or_cm(phantom, analysed, tmp_path):
    out, _ = analysed
    work = tmp_path / "unmarked"
    work.mkdir()
    for part in ("inputs.json", "fingerprints.json", "images", "sfm"):  # SfM is reused; scale onwards reruns
        (shutil.copytree if (out / part).is_dir() else shutil.copy)(out / part, work / part)
    for image in (work / "images").iterdir():
        image.unlink()
        shutil.copy(phantom / "images" / image.name, image)
    hide_marker(phantom, work / "images")
    result = analyze(Config(), phantom / "images", work, masks=phantom / "masks")
    assert result.status is AnalysisStatus.unscaled and "not reported in mm or cm" in result.reason
    assert result.scale.method == "none" and result.scale.mm_per_unit is None
    m = result.metrics
    for field in (
        "area_cm2",
        "perimeter_cm",
        "relief_max_mm",
        "relief_mean_mm",
        "raised_max_mm",
        "volume_cm3",
        "tbsa_percent",
    ):
        assert getattr(m, field) is None, field
    assert m.area_model_units2 > 0 and result.reference.ring_rms_mm is None
    assert result.confidence.level == "low" and any("no scale" in r for r in result.confidence.reasons)
    assert "cm" not in json.dumps(msgspec.to_builtins(result.metrics)).replace("_cm", "")


def test_stage_failures_still_write_a_result_and_bad_requests_touch_nothing(phantom, analysed, tmp_path):
    out, _ = analysed
    work = tmp_path / "analysis"
    shutil.copytree(out, work)
    before = (work / "analysis.json").read_bytes()
    for bad in (
        {"masks": work / "segmentation" / "masks"},
        {"patient": Patient(hours_since_injury=-2)},
        {"patient": Patient(height_cm=170)},
        {"patient": Patient(height_cm=170, weight_kg=900)},
    ):
        with pytest.raises(InvalidInput):
            analyze(Config(), phantom / "images", work, **bad)
        assert (work / "analysis.json").read_bytes() == before  # refused before anything was removed
    masks = tmp_path / "masks"
    shutil.copytree(phantom / "masks", masks)
    cv2.imwrite(str(masks / "view_002.png"), np.zeros((10, 10), np.uint8))
    (masks / "IMG_9999.json").write_text('{"polygons": [[[0, 0], [5, 0], [5, 5]]]}')
    result = analyze(Config(), phantom / "images", work, masks=masks)
    assert result.status is AnalysisStatus.failed and result.failure is FailureCode.bad_input
    assert "view_002.png" in result.reason and "as stored" in result.reason
    assert json.loads((work / "analysis.json").read_text())["status"] == "failed"
    (masks / "view_002.png").unlink()
    result = analyze(Config(), phantom / "images", work, masks=masks)
    assert result.status is AnalysisStatus.ok and any("IMG_9999" in n for n in result.notes)


def test_a_person_outline_replaces_the_model_for_that_view(phantom, tmp_path):
    masks = tmp_path / "given"
    masks.mkdir()
    square = [[100, 100], [300, 100], [300, 260], [100, 260]]
    (masks / "view_001.json").write_text(json.dumps({"polygons": [square]}))
    pictures = ["view_000.jpg", "view_001.jpg"]
    record = segment_views.run(AnalysisConfig(), phantom / "images", pictures, tmp_path / "seg", masks)
    views = {v["image"]: v for v in json.loads(record.read_text())["views"]}
    assert views["view_001.jpg"]["source"] == "clinician_outline" and views["view_000.jpg"]["source"] == "model"
    drawn = cv2.imread(str(tmp_path / "seg" / "masks" / "view_001.png"), cv2.IMREAD_GRAYSCALE) > 0
    assert drawn[180, 200] and not drawn[50, 50] and drawn.sum() == pytest.approx(201 * 161, rel=0.02)


@pytest.mark.parametrize(
    ("name", "content", "why"),
    [
        ("view_000.png", "small-png", "draw the mask on the picture as stored"),
        ("view_000.json", '{"polygons": [[[1, 2], [3, 4]]]}', "at least 3 points"),
        ("view_000.json", '{"outline": []}', "expected"),
    ],
)
def test_bad_person_masks_are_refused_with_a_reason(phantom, tmp_path, name, content, why):
    masks = tmp_path / "given"
    masks.mkdir()
    if content == "small-png":
        cv2.imwrite(str(masks / name), np.zeros((10, 10), np.uint8))
    else:
        (masks / name).write_text(content)
    with pytest.raises(InvalidInput, match=why):
        segment_views.run(AnalysisConfig(), phantom / "images", ["view_000.jpg"], tmp_path / "seg", masks)


def test_burnedge_segment_writes_a_mask_and_a_probability_per_photo(phantom, tmp_path):
    photos = tmp_path / "photos"
    photos.mkdir()
    for name in ("view_000.jpg", "view_003.jpg"):
        shutil.copy(phantom / "images" / name, photos / name)
    r = cli("segment", str(photos), "--out", str(tmp_path / "out"))
    assert r.returncode == 0, r.stderr
    for stem in ("view_000", "view_003"):
        mask = cv2.imread(str(tmp_path / "out" / f"{stem}.png"), cv2.IMREAD_GRAYSCALE)
        prob = cv2.imread(str(tmp_path / "out" / f"{stem}.probability.png"), cv2.IMREAD_GRAYSCALE)
        assert mask.shape == prob.shape == (SMALL["height"], SMALL["width"])
        assert set(np.unique(mask)) <= {0, 255}
        np.testing.assert_array_equal(mask > 0, prob >= 128)
    assert cli("segment", str(tmp_path / "nothing"), "--out", str(tmp_path / "o")).returncode == 3


def test_the_shipped_model_runs_on_a_crop_and_on_the_whole_picture(phantom):
    segmenter = BurnSegmenter(SHIPPED_MODEL)
    rgb = cv2.cvtColor(cv2.imread(str(phantom / "images" / "view_000.jpg")), cv2.COLOR_BGR2RGB)
    truth = cv2.imread(str(phantom / "masks" / "view_000.png"), cv2.IMREAD_GRAYSCALE) > 0
    ys, xs = np.nonzero(truth)
    box = Box.around(xs.mean(), ys.mean(), 2.2 * max(np.ptp(xs), np.ptp(ys)) / 2, rgb.shape[1], rgb.shape[0])
    prob = segmenter.probability(rgb, box)
    assert prob.shape == truth.shape and prob.min() >= 0 and prob.max() <= 1
    found = prob >= 0.5
    dice = 2 * (found & truth).sum() / (found.sum() + truth.sum())
    assert dice > 0.6, dice
    outside = np.ones_like(found)
    outside[box.y0 : box.y0 + box.side, box.x0 : box.x0 + box.side] = False
    assert box.side < min(rgb.shape[:2]) and not found[outside].any()  # nothing outside the crop
    with pytest.raises(InvalidInput, match="RGB uint8"):
        segmenter.probability(rgb[..., 0])
    with pytest.raises(InvalidInput, match="not found"):
        BurnSegmenter("/nonexistent/model.onnx")


def test_confidence_falls_with_each_weak_indicator():
    good = confidence.score(12, 10, 0.8, 0.5, 1.0, 0.3, 0)
    assert good.level == "high" and good.reasons == []
    for weak, words in [
        ({"seen3": 0.4}, "3 or more angles"),
        ({"scale_uncertainty_percent": 3.0}, "scale"),
        ({"views_seeing_burn": 3}, "only 3 photos"),
        ({"reprojection_px": 2.5}, "loosely"),
    ]:
        args = {
            "views_used": 12,
            "views_seeing_burn": 10,
            "inlier_ratio": 0.8,
            "reprojection_px": 0.5,
            "seen3": 1.0,
            "scale_uncertainty_percent": 0.3,
            "clinician_masks": 0,
        } | weak
        worse = confidence.score(**args)
        assert worse.score < good.score and any(words in r for r in worse.reasons), (weak, worse)


def test_provisional_only_before_72_hours(phantom, analysed):
    out, _ = analysed
    later = analyze(Config(), phantom / "images", out, masks=phantom / "masks", patient=Patient(hours_since_injury=96))
    assert later.provisional is False and later.hours_since_injury == 96
