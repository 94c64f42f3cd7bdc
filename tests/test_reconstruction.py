"""The reconstruction stages on small rendered phantoms: real COLMAP, real stereo, real files."""

from __future__ import annotations

import hashlib
import json
import shutil
import subprocess
import sys
from pathlib import Path

import cv2
import msgspec
import numpy as np
import pycolmap
import pytest
import trimesh

from harness.processes import REPO
from processing.capture.marker import find_markers
from processing.phantom.generate import run as render_phantom
from processing.reconstruction import pipeline, scale
from processing.reconstruction.evaluation import evaluate
from processing.reconstruction.marker_edges import linear_intensity, refine_quad
from processing.reconstruction.sfm import video_pairs
from schemas.config import Config
from schemas.errors import CaptureInsufficient
from schemas.phantom import PhantomShape, PhantomSpec
from schemas.reconstruction import FailureCode, Outcome, ReconstructionReport, RulerMark, RulerPoints, ScaleSource
from tests.conftest import SHARED
from tests.phantom_helpers import hide_marker

SMALL = {"views": 8, "width": 960, "height": 720}


def _digest(folder: Path) -> dict[str, str]:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.iterdir())}


@pytest.fixture(scope="module")
def phantom(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("phantom")
    render_phantom(PhantomSpec(shape=PhantomShape.forearm, seed=3, **SMALL), out)
    return out


@pytest.fixture(scope="module")
def analysis(phantom, tmp_path_factory) -> tuple[Path, ReconstructionReport, dict[str, str]]:
    before = _digest(phantom / "images")
    out = tmp_path_factory.mktemp("analysis")
    report = pipeline.run(Config(), phantom / "images", out)
    return out, report, before


def test_a_phantom_becomes_a_scaled_mesh_close_to_the_truth(phantom, analysis):
    out, report, _ = analysis
    assert report.outcome is Outcome.complete, report.reason
    assert report.sfm.images_used >= 6 and report.sfm.images_registered == report.sfm.images_used
    assert report.sfm.mean_reprojection_error_px < 1.0
    assert report.scale.source is ScaleSource.marker and report.dense.units == "mm"
    accuracy = evaluate(out, phantom)
    assert abs(accuracy.scale_error) < 0.005, accuracy
    # Half-size renders: twice the pixel footprint of the benchmark's, so a looser bound here.
    assert accuracy.surface_median_mm < 0.3 and accuracy.surface_p95_mm < 1.0, accuracy
    assert accuracy.surface_samples > 1000


def test_the_artifacts_open_in_other_tools(analysis):
    out, report, _ = analysis
    ply = trimesh.load(out / report.artifacts["mesh_ply"])
    assert len(ply.faces) == report.dense.mesh_faces
    glb = trimesh.load(out / report.artifacts["mesh_glb"])
    assert sum(len(g.faces) for g in glb.geometry.values()) == report.dense.mesh_faces
    model = pycolmap.Reconstruction(str(out / report.artifacts["sfm_model"]))
    assert model.num_reg_images() == report.sfm.images_registered
    stored = msgspec.json.decode((out / "report.json").read_bytes(), type=ReconstructionReport)
    assert stored == report


def test_inputs_are_left_untouched(phantom, analysis):
    _, _, before = analysis
    assert _digest(phantom / "images") == before


def test_a_finished_analysis_resumes_without_redoing_work(phantom, analysis, tmp_path):
    out, report, _ = analysis
    copy = tmp_path / "again"
    shutil.copytree(out, copy)
    again = pipeline.run(Config(), phantom / "images", copy)
    assert all(t.resumed for t in again.timings)
    (copy / "mesh" / "dense_quality.json").unlink()
    third = pipeline.run(Config(), phantom / "images", copy)
    assert [t.stage for t in third.timings if not t.resumed] == ["mesh"]
    # Open3D's Poisson solver is multi-threaded: a re-run may differ by a few triangles.
    assert third.dense.mesh_faces == pytest.approx(report.dense.mesh_faces, rel=1e-3)


@pytest.fixture
def unmarked(phantom, analysis, tmp_path) -> Path:
    """The analysis up to SfM, with the marker painted out of its pictures."""
    out, _, _ = analysis
    copy = tmp_path / "unmarked"
    copy.mkdir()
    for part in ("inputs.json", "fingerprints.json", "images", "sfm"):
        (shutil.copytree if (out / part).is_dir() else shutil.copy)(out / part, copy / part)
    for image in (copy / "images").iterdir():
        image.unlink()
        shutil.copy(phantom / "images" / image.name, image)
    hide_marker(phantom, copy / "images")
    return copy


def test_without_a_marker_nothing_is_in_millimetres(phantom, unmarked):
    report = pipeline.run(Config(), phantom / "images", unmarked)
    assert report.outcome is Outcome.complete
    assert report.scale.source is ScaleSource.none and report.scale.mm_per_unit is None
    assert "model units" in report.scale.note
    assert report.dense.units == "model units"


def _ruler(phantom: Path, views: int) -> RulerPoints:
    truth = json.loads((phantom / "ground_truth.json").read_text())
    corners = truth["marker"]["corners_world_mm"]
    ids = sorted(corners, key=int)
    a, b = np.array(corners[ids[0]][0]), np.array(corners[ids[-1]][2])
    marks = []
    for camera in truth["cameras"][:views]:
        K, R, t = (np.array(camera[k]) for k in ("K", "R", "t"))
        ends = [(K @ (R @ p + t))[:2] / (R @ p + t)[2] for p in (a, b)]
        marks.append(RulerMark(image=f"{camera['name']}.jpg", a=ends[0].tolist(), b=ends[1].tolist()))
    return RulerPoints(distance_mm=float(np.linalg.norm(a - b)), marks=marks)


def test_ruler_points_give_the_scale_when_there_is_no_marker(phantom, analysis, unmarked):
    out, report, _ = analysis
    ruler = _ruler(phantom, views=3)
    result = msgspec.json.decode(
        scale.run(
            Config().reconstruction, unmarked / "sfm" / "model", unmarked / "images", unmarked / "scale", ruler
        ).read_bytes(),
        type=scale.ScaleResult,
    )
    assert result.estimate.source is ScaleSource.ruler
    assert result.estimate.mm_per_unit == pytest.approx(report.scale.mm_per_unit, rel=0.01)
    assert result.estimate.relative_uncertainty < 0.02


def test_ruler_points_that_do_not_agree_are_refused(phantom, unmarked):
    ruler = _ruler(phantom, views=3)
    scrambled = [msgspec.structs.replace(m, a=[m.a[0] + 80 * i, m.a[1] - 60 * i]) for i, m in enumerate(ruler.marks)]
    with pytest.raises(CaptureInsufficient) as error:
        scale.run(
            Config().reconstruction,
            unmarked / "sfm" / "model",
            unmarked / "images",
            unmarked / "scale",
            msgspec.structs.replace(ruler, marks=scrambled),
        )
    assert error.value.code == FailureCode.bad_ruler and "same spot" in error.value.detail


def test_refined_marker_corners_sit_on_the_true_corners(phantom):
    truth = json.loads((phantom / "ground_truth.json").read_text())
    raw_errors, refined_errors = [], []
    for camera in truth["cameras"]:
        K, R, t = (np.array(camera[k]) for k in ("K", "R", "t"))
        gray = cv2.imread(str(phantom / "images" / f"{camera['name']}.jpg"), cv2.IMREAD_GRAYSCALE)
        for sighting in find_markers(gray, 1.0, "DICT_4X4_50"):
            world = np.array(truth["marker"]["corners_world_mm"][str(sighting.id)])
            cam = world @ R.T + t
            true = cam[:, :2] / cam[:, 2:] @ K[:2, :2].T + K[:2, 2]
            refined = refine_quad(linear_intensity(gray), np.array(sighting.corners_px))
            if refined is not None:
                raw_errors += list(np.linalg.norm(np.array(sighting.corners_px) - true, axis=1))
                refined_errors += list(np.linalg.norm(refined - true, axis=1))
    assert len(refined_errors) >= 24
    assert np.median(refined_errors) < 0.1 < np.median(raw_errors)


def test_too_few_pictures_is_a_clear_failure_and_the_cli_says_so(phantom, tmp_path):
    few = tmp_path / "few"
    few.mkdir()
    for name in sorted(p.name for p in (phantom / "images").iterdir())[:3]:
        shutil.copy(phantom / "images" / name, few / name)
    before = _digest(few)
    r = subprocess.run(
        [sys.executable, "-m", "burnedge.cli", "reconstruct", str(few), "--out", str(tmp_path / "out")],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 7, r.stderr
    report = msgspec.json.decode(r.stdout, type=ReconstructionReport)
    assert report.failure is FailureCode.too_few_views and "only 3 usable pictures" in report.reason
    assert "walking around the burn" in r.stderr
    assert _digest(few) == before


def test_pictures_from_one_spot_are_called_degenerate(phantom, tmp_path):
    """Pure camera rotations (homographies of one picture) carry no depth."""
    image = cv2.imread(str(phantom / "images" / "view_000.jpg"))
    h, w = image.shape[:2]
    K = np.array([[w * 0.78, 0, w / 2], [0, w * 0.78, h / 2], [0, 0, 1]])
    folder = tmp_path / "one-spot"
    folder.mkdir()
    for i, (yaw, pitch) in enumerate([(0, 0), (4, 0), (-4, 0), (0, 3), (3, 3), (-3, -3)]):
        R = cv2.Rodrigues(np.radians([pitch, yaw, 0.0]))[0]
        warped = cv2.warpPerspective(image, K @ R @ np.linalg.inv(K), (w, h), borderMode=cv2.BORDER_REFLECT)
        cv2.imwrite(str(folder / f"spot_{i}.jpg"), warped, [cv2.IMWRITE_JPEG_QUALITY, 95])
    report = pipeline.run(Config(), folder, tmp_path / "out")
    assert report.outcome is Outcome.failed and report.failure is FailureCode.degenerate_capture, report.reason
    assert "same spot" in report.reason or "one spot" in report.reason


def test_two_scenes_mixed_together_are_named(phantom, tmp_path):
    other = tmp_path / "other"
    render_phantom(PhantomSpec(shape=PhantomShape.foot, seed=11, marker_ids=[3, 7, 9], **SMALL), other)
    mixed = tmp_path / "mixed"
    mixed.mkdir()
    for source, prefix in ((phantom, "a"), (other, "b")):
        for name in sorted(p.name for p in (source / "images").iterdir())[:5]:
            shutil.copy(source / "images" / name, mixed / f"{prefix}_{name}")
    report = pipeline.run(Config(), mixed, tmp_path / "out")
    assert report.outcome is Outcome.failed and report.failure is FailureCode.mixed_scenes, report.reason
    assert "a_view_000.jpg" in report.reason and "b_view_000.jpg" in report.reason


def test_video_frames_are_matched_in_sequence_and_back_to_the_start(tmp_path):
    names = [f"f{i:02d}.jpg" for i in range(10)]
    rng = np.random.default_rng(0)
    scenes = [rng.integers(0, 255, (48, 64), dtype=np.uint8) for _ in range(10)]
    scenes[9] = scenes[0]  # the orbit comes back to where it started
    for name, pixels in zip(names, scenes, strict=True):
        cv2.imwrite(str(tmp_path / name), cv2.resize(pixels, (640, 480), interpolation=cv2.INTER_NEAREST))
    sequential = video_pairs(tmp_path, names, overlap=2, loop_candidates=0)
    assert sequential == [(names[i], names[j]) for i in range(10) for j in range(i + 1, min(i + 3, 10))]
    pairs = video_pairs(tmp_path, names, overlap=2, loop_candidates=1)
    assert set(sequential) < set(pairs)
    assert ("f00.jpg", "f09.jpg") in pairs  # the most similar earlier frame closes the loop


@pytest.mark.skipif(not (SHARED / "phantoms" / "p2_foot" / "video.mp4").exists(), reason="needs ../shared/phantoms")
def test_a_phone_video_is_placed_from_its_frames(tmp_path):
    from processing.reconstruction import inputs, sfm
    from schemas.reconstruction import InputSet

    config = Config()
    record = msgspec.json.decode(
        inputs.run(config, SHARED / "phantoms" / "p2_foot" / "video.mp4", tmp_path).read_bytes(), type=InputSet
    )
    assert record.video and len(record.pictures) >= 10
    sfm.run(config.reconstruction, tmp_path / "images", record.pictures, tmp_path / "sfm", video=True)
    quality = json.loads((tmp_path / "sfm" / "sfm_quality.json").read_text())
    assert quality["matching"] == "sequential+loop"
    assert quality["images_registered"] >= 0.9 * len(record.pictures)
    assert quality["mean_reprojection_error_px"] < 1.0


def test_our_cameras_use_opencv_pixel_centres(analysis):
    """COLMAP puts pixel centres at +0.5; View.project must land on keypoints shifted by -0.5."""
    from processing.reconstruction.views import load_views

    out, report, _ = analysis
    model = pycolmap.Reconstruction(str(out / report.artifacts["sfm_model"]))
    views = {v.image_id: v for v in load_views(model)}
    ours, unshifted = [], []
    for point in list(model.points3D.values())[:300]:
        for element in point.track.elements:
            keypoint = np.array(model.images[element.image_id].points2D[element.point2D_idx].xy)
            projected = views[element.image_id].project(point.xyz[None, :])[0][0]
            ours.append(np.linalg.norm(projected - (keypoint - 0.5)))
            unshifted.append(np.linalg.norm(projected - keypoint))
    assert np.median(ours) < 0.5 * np.median(unshifted)


def _synthetic_views(count: int) -> list:
    from processing.reconstruction.views import View

    K = np.array([[1000.0, 0, 640], [0, 1000.0, 480], [0, 0, 1]])
    views = []
    for i in range(count):
        angle = np.radians(-20 + 40 * i / max(count - 1, 1))
        R = cv2.Rodrigues(np.array([np.pi + 0.3, angle, 0.0]))[0]
        t = -R @ np.array([200 * np.sin(angle), -90.0, 250.0])
        views.append(View(f"v{i}.jpg", i + 1, 1280, 960, K, np.zeros(4), R, t))
    return views


def _sightings(views, quads: dict[int, np.ndarray]) -> dict:
    found = {}
    for marker_id, quad in quads.items():
        found[marker_id] = [[(v, v.project(quad[k][None, :])[0][0]) for v in views] for k in range(4)]
    return found


def test_a_bent_marker_is_not_trusted_for_scale():
    views = _synthetic_views(4)
    square = np.array([[0, 0, 0], [20, 0, 0], [20, -20, 0], [0, -20, 0]], dtype=float)
    good = scale.from_marker(Config().reconstruction, _sightings(views, {1: square}), views)
    assert good.estimate.source is ScaleSource.marker and good.estimate.mm_per_unit == pytest.approx(1.0, rel=1e-4)
    assert good.estimate.relative_uncertainty >= scale.SCALE_FLOOR
    bent = square.copy()
    bent[2] += [1.5, -1.5, 3.0]  # one corner lifted off the skin: two sides and a diagonal are wrong
    result = scale.from_marker(Config().reconstruction, _sightings(views, {1: bent}), views)
    assert result.estimate.source is ScaleSource.none and result.estimate.mm_per_unit is None
    assert "disagree" in result.estimate.note


def test_adding_a_ruler_later_reruns_the_scale_and_what_follows(phantom, unmarked):
    first = pipeline.run(Config(), phantom / "images", unmarked)
    assert first.scale.source is ScaleSource.none
    second = pipeline.run(Config(), phantom / "images", unmarked, _ruler(phantom, views=3))
    assert [t.stage for t in second.timings if not t.resumed] == ["scale", "dense", "mesh"]
    assert second.scale.source is ScaleSource.ruler and second.dense.units == "mm"


def test_fresh_refuses_to_delete_the_pictures(phantom, tmp_path):
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "burnedge.cli",
            "reconstruct",
            str(phantom / "images"),
            "--out",
            str(phantom),
            "--fresh",
        ],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert r.returncode == 2 and "overlaps the pictures" in r.stderr
    assert len(list((phantom / "images").iterdir())) == 8


def test_pictures_that_cannot_be_placed_get_a_retake_request_after_a_thorough_retry(phantom, tmp_path):
    folder = tmp_path / "half-unplaceable"
    folder.mkdir()
    # Pictures at three quarters of the size: the same failure, with about half the pixels for the thorough retry's
    # SIFT (on doubled pictures) to search.
    for name in sorted(p.name for p in (phantom / "images").iterdir())[:4]:
        picture = cv2.imread(str(phantom / "images" / name))
        cv2.imwrite(str(folder / name), cv2.resize(picture, (720, 540), interpolation=cv2.INTER_AREA))
    rng = np.random.default_rng(5)
    for i in range(4):  # sharp, well exposed, but of nothing the other pictures show
        coarse = rng.integers(0, 255, (24, 32, 3), dtype=np.uint8)  # smooth blobs: few features, fast to match
        noise = cv2.resize(coarse, (720, 540), interpolation=cv2.INTER_CUBIC)
        cv2.imwrite(str(folder / f"other_{i}.jpg"), noise, [cv2.IMWRITE_JPEG_QUALITY, 92])
    report = pipeline.run(Config(), folder, tmp_path / "out", gate=False)  # the gate would refuse the noise
    assert report.outcome is Outcome.failed and report.failure is FailureCode.too_few_placed, report.reason
    assert "of 8 pictures could be placed" in report.reason and "walking around the burn" in report.reason
    assert (tmp_path / "out" / "sfm" / "work" / "database.db").exists()  # the thorough attempt's, kept for IT
