"""Capture-set readiness: enough usable views, the marker in some, and views from around the burn."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from harness.bodies import encounter_body, patient_body
from processing.capture.quality import gate_bytes, gate_file
from processing.capture.readiness import FULL_FRAME_DIAGONAL_MM, View, assess, pose_errors, viewing_direction
from schemas.capture import MarkerSighting, QualityFigures, QualityVerdict
from schemas.config import QualityGateConfig, ReadinessConfig
from tests.capture_images import jpeg, scene
from tests.conftest import SHARED
from tests.test_uploads import upload

GATE, READY = QualityGateConfig(), ReadinessConfig()
THIGH = SHARED / "phantoms" / "p3_thigh"
needs_phantoms = pytest.mark.skipif(not THIGH.exists(), reason="needs ../shared/phantoms (the shared data set)")


def _true_spread(scene_dir: Path) -> float:
    gt = json.loads((scene_dir / "ground_truth.json").read_text())
    centre = np.array([c for corners in gt["marker"]["corners_world_mm"].values() for c in corners]).mean(axis=0)
    dirs = []
    for cam in gt["cameras"]:
        c = -np.array(cam["R"]).T @ np.array(cam["t"]).ravel()
        dirs.append((c - centre) / np.linalg.norm(c - centre))
    return max(float(np.degrees(np.arccos(np.clip(a @ b, -1, 1)))) for i, a in enumerate(dirs) for b in dirs[i + 1 :])


@needs_phantoms
def test_a_full_phantom_set_is_ready_and_its_spread_is_measured_from_the_marker():
    views = [View(gate_file(p, GATE)) for p in sorted((THIGH / "images").glob("*.jpg"))]
    r = assess(views, READY, GATE)
    assert r.ready and r.missing == [] and r.accepted_views == r.marker_views == 12
    assert r.viewpoint_spread_deg == pytest.approx(_true_spread(THIGH), abs=5.0)


@needs_phantoms
def test_too_few_views_or_one_spot_is_not_ready_and_says_what_to_do():
    view = View(gate_file(THIGH / "images" / "view_000.jpg", GATE))
    few = assess([view] * 3, READY, GATE)
    assert not few.ready and "At least 6" in few.missing[0] and "(3 so far)" in few.missing[0]
    one_spot = assess([view] * 6, READY, GATE)
    assert not one_spot.ready and one_spot.viewpoint_spread_deg == 0.0 and "walk around" in one_spot.missing[0]


def test_views_without_the_marker_are_not_ready():
    views = [View(gate_bytes(jpeg(scene(marker_px=0, seed=s)), GATE, name=f"{s}.jpg")) for s in range(6)]
    r = assess(views, READY, GATE)
    assert not r.ready and r.accepted_views == 6 and r.marker_views == 0 and r.viewpoint_spread_deg is None
    assert any("scale marker" in m for m in r.missing)


@needs_phantoms
def test_readiness_over_the_api_follows_the_uploads(client, auth):
    h = auth["nurse"]
    p = patient_body()
    client.post("/api/v1/patients", json=p, headers=h)
    e = encounter_body(p["id"])
    client.post("/api/v1/encounters", json=e, headers=h)
    url = f"/api/v1/encounters/{e['id']}/capture-readiness"
    assert client.get(url, headers=h).json()["ready"] is False
    for path in sorted((THIGH / "images").glob("*.jpg"))[:6]:
        upload(client, h, e["id"], path.read_bytes(), path.name)
    upload(client, h, e["id"], (THIGH / "defects" / "view_001_motion_blur.jpg").read_bytes(), "shaky.jpg")
    r = client.get(url, headers=h).json()
    assert r["ready"] and r["views"] == 7 and r["accepted_views"] == 6 and r["viewpoint_spread_deg"] > 20
    assert client.get(url, headers=auth["admin"]).status_code == 403


W, H = 1600, 1200


def _direction(tilt_deg: float, azimuth_deg: float) -> np.ndarray:
    a, b = np.radians(tilt_deg), np.radians(azimuth_deg)
    return np.array([np.sin(a) * np.cos(b), np.sin(a) * np.sin(b), np.cos(a)])


def _sighting(
    marker_id: int,
    tilt_deg: float,
    azimuth_deg: float = 0.0,
    distance_mm: float = 200.0,
    noise_px: float = 0.0,
    seed: int = 0,
) -> MarkerSighting:
    """The marker's corners seen by a camera at `distance_mm` from it, looking at it from that direction."""
    c = distance_mm * _direction(tilt_deg, azimuth_deg)
    z = -c / np.linalg.norm(c)
    x = np.cross([0.0, 1.0, 0.0], z)
    x /= np.linalg.norm(x)
    rotation = np.stack([x, np.cross(z, x), z])
    f = READY.default_focal_35mm / FULL_FRAME_DIAGONAL_MM * np.hypot(W, H)
    k = np.array([[f, 0, W / 2], [0, f, H / 2], [0, 0, 1]])
    half = GATE.marker_side_mm / 2
    square = np.array([[-half, half, 0], [half, half, 0], [half, -half, 0], [-half, -half, 0]])
    pts, _ = cv2.projectPoints(square, cv2.Rodrigues(rotation)[0], -rotation @ c, k, None)
    pts = pts.reshape(4, 2) + np.random.default_rng(seed).normal(0, noise_px, (4, 2))
    side = float(np.mean(np.linalg.norm(pts - np.roll(pts, 1, axis=0), axis=1)))
    return MarkerSighting(id=marker_id, side_px=side, corners_px=pts.tolist())


def _view(*sightings: MarkerSighting) -> View:
    figures = QualityFigures(
        width=W,
        height=H,
        analysis_long_side=1000,
        sharpness=500.0,
        local_sharpness=500.0,
        mean_intensity=120.0,
        dark_fraction=0.0,
        bright_fraction=0.0,
        markers=list(sightings),
        seconds=0.01,
    )
    return View(QualityVerdict(file="view.jpg", accepted=True, reasons=[], guidance=[], figures=figures))


def test_views_showing_different_markers_are_not_mixed():
    # Markers 7 and 9 of a strip lie on differently curved skin: a direction measured from one is
    # meaningless in the other's frame. Marker 7 is in the most views, so only its sightings count,
    # even where 9 is also seen (and larger).
    views = [
        _view(_sighting(7, 20, 0)),
        _view(_sighting(7, 20, 180)),
        _view(_sighting(7, 15, 80), _sighting(9, 60, 0, distance_mm=120)),  # not 90: exact symmetry upsets IPPE
        _view(_sighting(7, 15, 260)),
        _view(_sighting(9, 60, 180)),
        _view(_sighting(9, 50, 90)),
    ]
    r = assess(views, READY, GATE)
    assert r.marker_views == 4 and r.viewpoint_spread_deg == pytest.approx(40.0, abs=0.5)
    assert r.ready


def test_a_flipped_marker_pose_does_not_invent_a_spread():
    # A small marker with noisy corners: the mirrored pose happens to fit best (by 5x), 38 degrees off.
    noisy = _view(_sighting(7, 20, 0, distance_mm=600, noise_px=0.2, seed=25))
    best, _, _ = pose_errors(noisy, noisy.verdict.figures.markers[0], GATE.marker_side_mm, READY.default_focal_35mm)
    assert np.degrees(np.arccos(best @ _direction(20, 0))) > 30  # the scenario, as set up
    assert viewing_direction(noisy, 7, GATE.marker_side_mm, READY.default_focal_35mm) is None
    assert viewing_direction(noisy, 9, GATE.marker_side_mm, READY.default_focal_35mm) is None  # not in the view
    r = assess([_view(_sighting(7, 20, 0)), _view(_sighting(7, 20, 0, distance_mm=250)), noisy] * 2, READY, GATE)
    assert r.marker_views == 4 and r.viewpoint_spread_deg == pytest.approx(0.0, abs=1.0)
    assert not r.ready and "walk around" in r.missing[0]


def test_a_marker_seen_only_head_on_says_so():
    views = [_view(_sighting(7, 4, 0, distance_mm=400, noise_px=0.2, seed=s)) for s in range(6)]
    r = assess(views, READY, GATE)
    assert r.marker_views == 0 and r.viewpoint_spread_deg is None
    assert not r.ready and "straight on" in r.missing[0]
