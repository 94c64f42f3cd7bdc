"""Capture-set readiness: enough usable views, the marker in some, and views from around the burn."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from processing.capture.quality import gate_bytes, gate_file
from processing.capture.readiness import View, assess
from schemas.config import QualityGateConfig, ReadinessConfig
from tests.capture_images import jpeg, scene
from tests.conftest import SHARED, encounter_body, patient_body
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
