"""Healing over time: the healing figures and prompts, registration on a synthetic limb moved by a known
transform, track.run on hand-made analysis folders, bad input, and `burnedge track` end to end on a small
rendered series against its ground truth."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import msgspec
import numpy as np
import open3d as o3d
import pytest
from scipy import ndimage, stats

from benchmarks.healing_track import eval_skin, rms_apart, to_world
from burnedge.cli import main as cli_main
from harness.processes import REPO
from processing.longitudinal import healing, registration, track
from processing.phantom.generate import run_series
from processing.stages import write_json
from schemas.analysis import AnalysisResult, AnalysisStatus, BurnMetrics
from schemas.config import TrackingConfig
from schemas.errors import InvalidInput
from schemas.longitudinal import TrackResult
from schemas.phantom import PhantomSpec
from schemas.reconstruction import FailureCode

CONF = TrackingConfig()


def cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "burnedge.cli", *args], capture_output=True, text=True, cwd=REPO, timeout=600
    )


# --- healing figures ---------------------------------------------------------------------------------------------


def test_change_against_the_baseline_has_the_documented_signs():
    c = healing.change(healing.Figures(16.0, 2.0, 1.0), healing.Figures(12.0, 1.5, 0.6))
    assert c.area_change_cm2 == pytest.approx(-4.0)
    assert c.area_change_percent == pytest.approx(-25.0) and c.percent_area_reduction == pytest.approx(25.0)
    assert c.relief_change_mm == pytest.approx(-0.5) and c.volume_change_cm3 == pytest.approx(-0.4)
    grown = healing.change(healing.Figures(10.0), healing.Figures(12.5, 1.0, None))
    assert grown.area_change_percent == pytest.approx(25.0) and grown.percent_area_reduction == pytest.approx(-25.0)
    assert grown.relief_change_mm is None and grown.volume_change_cm3 is None


def test_healing_rate_is_the_least_squares_slope_over_every_visit_positive_when_shrinking():
    days, areas = [0, 5, 9, 16, 30], [20.0, 17.5, 14.0, 11.0, 2.5]
    rate = healing.healing_rate(days, areas)
    slope, _ = np.polyfit(days, areas, 1)
    assert rate.rate_cm2_per_day == pytest.approx(-slope) and rate.rate_cm2_per_day > 0
    assert rate.rate_cm2_per_day != pytest.approx((areas[0] - areas[-1]) / 30)  # not the first-to-last slope
    residuals = np.array(areas) - np.polyval(np.polyfit(days, areas, 1), days)
    sxx = np.sum((np.array(days) - np.mean(days)) ** 2)
    assert rate.se_cm2_per_day == pytest.approx(math.sqrt(np.sum(residuals**2) / 3 / sxx))
    assert healing.healing_rate([0, 7], [10.0, 12.0]).rate_cm2_per_day == pytest.approx(-2 / 7)
    for days, areas in (([3.0], [10.0]), ([4.0, 4.0], [10.0, 9.0])):
        lone = healing.healing_rate(days, areas)
        assert lone.rate_cm2_per_day is None and "two different days" in lone.reason


def test_projected_closure_on_an_exact_line_is_its_zero_crossing():
    p = healing.projected_closure(healing.healing_rate([0, 7, 14, 21], [16.0, 12.0, 8.0, 4.0]))
    assert p.day == pytest.approx(28.0) and p.earliest == pytest.approx(28.0) and p.latest == pytest.approx(28.0)


def test_projected_closure_range_is_fieller_interval_at_95_percent():
    days, areas = np.array([0.0, 4, 9, 13, 20]), np.array([18.0, 16.1, 11.2, 10.4, 5.3])
    rate = healing.healing_rate(list(days), list(areas))
    p = healing.projected_closure(rate)
    assert p.earliest < p.day < p.latest and p.note == ""
    # The ends are where a zero mean area stops being compatible with the line (checked independently here).
    slope, intercept = np.polyfit(days, areas, 1)
    s = np.sqrt(np.sum((areas - (intercept + slope * days)) ** 2) / 3)
    t = stats.t.ppf(0.975, 3)
    mean_x, sxx = days.mean(), np.sum((days - days.mean()) ** 2)

    def excess(x):  # < 0: zero area is inside the 95 % band of the line's mean at day x
        return abs(intercept + slope * x) - t * s * math.sqrt(1 / 5 + (x - mean_x) ** 2 / sxx)

    assert excess(p.earliest) == pytest.approx(0, abs=1e-6) and excess(p.latest) == pytest.approx(0, abs=1e-6)
    assert excess(p.day) < 0 and excess(p.earliest - 0.5) > 0 and excess(p.latest + 0.5) > 0


def test_no_projection_without_three_visits_or_when_not_shrinking_and_an_open_end_when_uncertain():
    two = healing.projected_closure(healing.healing_rate([0, 7], [10.0, 8.0]))
    assert two.day is None and "three measured visits" in two.note
    growing = healing.projected_closure(healing.healing_rate([0, 7, 14], [10.0, 10.5, 11.2]))
    assert growing.day is None and "not shrinking" in growing.note
    noisy = healing.projected_closure(healing.healing_rate([0, 7, 14], [16.0, 10.0, 11.0]))
    assert noisy.day is not None and noisy.latest is None and "not certain" in noisy.note


def test_four_week_rule_triggers_below_40_percent_and_waits_for_4_weeks():
    slow = healing.shrink_flag(CONF, [0, 14, 28], [10.0, 8.0, 7.0])
    assert slow.evaluable and slow.triggered and "30 %" in slow.detail and "Kantor" in slow.citation
    assert "consider a clinical review" in slow.detail
    good = healing.shrink_flag(CONF, [0, 14, 30], [10.0, 7.0, 5.5])
    assert good.evaluable and not good.triggered and "45 %" in good.detail
    early = healing.shrink_flag(CONF, [3, 10, 24], [10.0, 9.5, 9.0])  # 21 days after the first measured visit
    assert not early.evaluable and not early.triggered and early.detail.startswith("not yet evaluable")
    latest = healing.shrink_flag(CONF, [0, 28, 35], [10.0, 7.0, 5.0])  # judged on the latest visit at >= 4 weeks
    assert latest.evaluable and not latest.triggered and "day 35" in latest.detail


def test_day_21_rule_triggers_on_an_open_burn_and_counts_a_tiny_one_as_healed():
    open_burn = healing.day21_flag(CONF, [0, 7, 21], [10.0, 6.0, 2.0])
    assert open_burn.evaluable and open_burn.triggered and "Deitch" in open_burn.citation
    assert "consider review by the burn team" in open_burn.detail
    healed = healing.day21_flag(CONF, [0, 10, 24], [10.0, 3.0, 0.2])
    assert healed.evaluable and not healed.triggered and "confirm on examination" in healed.detail
    early = healing.day21_flag(CONF, [0, 14], [10.0, 6.0])
    assert not early.evaluable and not early.triggered and early.detail.startswith("not yet evaluable")


def test_projected_day_21_rule_looks_ahead_until_day_21_is_reached():
    days = [0, 7, 14]
    late = healing.projected_day21_flag(
        CONF, days, healing.projected_closure(healing.healing_rate(days, [16.0, 12, 8]))
    )
    assert late.evaluable and late.triggered and "day 28" in late.detail
    quick = healing.projected_day21_flag(
        CONF, days, healing.projected_closure(healing.healing_rate(days, [9.0, 5.5, 2]))
    )
    assert quick.evaluable and not quick.triggered
    past = healing.projected_day21_flag(CONF, [0, 21], healing.Projection(30.0, 25.0, 35.0))
    assert not past.evaluable and past.detail.startswith("not needed")
    unknown = healing.projected_day21_flag(
        CONF, [0, 7], healing.projected_closure(healing.healing_rate([0, 7], [9.0, 5.0]))
    )
    assert not unknown.evaluable and "three measured visits" in unknown.detail


# --- registration on a synthetic limb ----------------------------------------------------------------------------

LIMB_RADIUS_MM, BURN_CENTRE = 38.0, np.array([-12.0, 8.0])


def _texture(seed: int) -> np.ndarray:
    """Freckle-like grey pattern on the limb's chart (0.25 mm pixels over 240 x 200 mm)."""
    noise = np.random.default_rng(seed).normal(size=(800, 960))
    return 0.5 + 0.08 * ndimage.gaussian_filter(noise, 3.0) / ndimage.gaussian_filter(noise, 3.0).std()


def _limb_height(x: np.ndarray, y: np.ndarray, bumps: list[tuple[float, float, float]]) -> np.ndarray:
    """A tapered half-cylinder along x lying on the drape (z = 0), with a few gentle bumps."""
    radius = LIMB_RADIUS_MM * (1 - 0.1 * (x + 120) / 240)
    height = np.sqrt(np.clip(radius**2 - y**2, 0, None))
    for bx, by, amp in bumps:
        height = height + amp * np.exp(-((x - bx) ** 2 + (y - by) ** 2) / (2 * 8.0**2)) * (height > 0)
    return height


@dataclass(frozen=True)
class Synthetic:
    surface: registration.Surface
    faces: np.ndarray


def synthetic_surface(
    turn_deg: float,
    shift: tuple[float, float],
    burn_radius_mm: float,
    texture_seed: int = 3,
    bumps=((30.0, -20.0, 1.5), (-45.0, 15.0, 1.0), (10.0, 25.0, -1.2)),
) -> Synthetic:
    """The limb turned about the vertical and shifted on a drape that stays put: vertices in the visit's frame;
    its true transform to the unmoved limb's frame is the inverse of that motion."""
    step = 0.5
    gx, gy = np.meshgrid(np.arange(-90, 90 + step, step), np.arange(-70, 70 + step, step))
    a = math.radians(turn_deg)
    rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    chart = (np.stack([gx.ravel(), gy.ravel()], 1) - np.array(shift)) @ rot  # world -> limb chart (R^T (p - t))
    z = _limb_height(chart[:, 0], chart[:, 1], list(bumps))
    vertices = np.column_stack([gx.ravel(), gy.ravel(), z])
    vertices += np.random.default_rng(7).normal(scale=0.03, size=vertices.shape)  # reconstruction noise
    rows, cols = gx.shape
    idx = np.arange(rows * cols).reshape(rows, cols)
    quads = np.stack([idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()], 1)
    faces = np.vstack([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    pixel = (chart + [120.0, 100.0]) / 0.25
    grey = ndimage.map_coordinates(_texture(texture_seed), [pixel[:, 1], pixel[:, 0]], order=1, mode="nearest")
    grey[z <= 0] = 0.35  # the drape: plain cloth
    burn = (np.linalg.norm(chart - BURN_CENTRE, axis=1) < burn_radius_mm) & (z > 0)
    mesh = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(vertices), o3d.utility.Vector3iVector(faces))
    mesh.compute_vertex_normals()
    surface = registration.Surface(vertices=vertices, normals=np.asarray(mesh.vertex_normals), burn=burn, grey=grey)
    return Synthetic(surface, faces)


def motion(turn_deg: float, shift: tuple[float, float]) -> np.ndarray:
    a = math.radians(turn_deg)
    m = np.eye(4)
    m[:2, :2] = [[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]]
    m[:2, 3] = shift
    return m


@pytest.fixture(scope="module")
def baseline_limb() -> Synthetic:
    return synthetic_surface(0.0, (0.0, 0.0), 20.0)


@pytest.fixture(scope="module")
def moved_limb() -> Synthetic:
    """Turned, shifted, the burn shrunk; the drape not moved."""
    return synthetic_surface(155.0, (12.0, -7.0), 12.0)


def test_registration_recovers_a_known_limb_motion_on_healthy_skin_and_ignores_the_drape(baseline_limb, moved_limb):
    follow = moved_limb.surface
    result = registration.register(CONF, baseline_limb.surface, follow)
    truth = np.linalg.inv(motion(155.0, (12.0, -7.0)))
    skin = follow.vertices[
        registration.skin_mask(CONF, follow, follow.burn_points, 25.0, [follow.burn_points], follow.vertices[:, 2] > 4)
    ]
    assert rms_apart(np.array(result.transform_to_baseline), truth, skin) < 0.3
    assert result.rmse_mm < 0.1 and result.overlap > 0.8 and result.warning == ""
    assert result.texture_agreement > 0.5 and result.ransac_agreeing >= 2 and result.burn_shift_mm < 2
    again = registration.register(CONF, baseline_limb.surface, follow)
    assert again.transform_to_baseline == result.transform_to_baseline  # seeded: a rerun repeats


def test_registration_of_a_different_limb_carries_a_warning(baseline_limb):
    stranger = synthetic_surface(40.0, (5.0, 5.0), 12.0, texture_seed=99, bumps=((-20.0, -25.0, 2.5),))
    result = registration.register(CONF, baseline_limb.surface, stranger.surface)
    assert "texture" in result.warning and "check that both visits show the same burn" in result.warning


# --- track.run on hand-made analysis folders ---------------------------------------------------------------------


def write_analysis(
    folder: Path,
    status: AnalysisStatus,
    limb: Synthetic | None = None,
    area: float | None = None,
    failure: FailureCode | None = None,
) -> Path:
    """An analysis folder as `burnedge analyze` leaves it, as far as the track reads it."""
    scaled = status is AnalysisStatus.ok
    metrics = BurnMetrics(
        area_cm2=area if scaled else None,
        perimeter_cm=10.0 if scaled else None,
        relief_max_mm=1.0 if scaled else None,
        volume_cm3=0.5 if scaled else None,
        area_model_units2=None if scaled else 3.0,
    )
    write_json(
        folder / "analysis.json",
        AnalysisResult(status=status, metrics=metrics, failure=failure, reason=None if scaled else "as the test says"),
    )
    if limb is not None:
        s = limb.surface
        (folder / "surface").mkdir(parents=True, exist_ok=True)
        np.savez_compressed(
            folder / track.SURFACE,
            vertices=s.vertices,
            faces=limb.faces,
            q=s.burn.astype(float),
            views_per_vertex=np.full(len(s.vertices), 4),
        )
        mesh = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(s.vertices), o3d.utility.Vector3iVector(limb.faces))
        mesh.vertex_colors = o3d.utility.Vector3dVector(np.repeat(s.grey[:, None], 3, axis=1))
        (folder / "mesh").mkdir(parents=True, exist_ok=True)
        o3d.io.write_triangle_mesh(str(folder / track.MESH), mesh)
    return folder


def test_track_lists_failed_unscaled_and_missing_visits_and_takes_the_first_scaled_one_as_baseline(
    tmp_path, baseline_limb, moved_limb
):
    visits = [
        track.SessionAnalysis(
            0, write_analysis(tmp_path / "a0", AnalysisStatus.failed, failure=FailureCode.too_few_placed)
        ),
        track.SessionAnalysis(2, write_analysis(tmp_path / "a1", AnalysisStatus.ok, baseline_limb, area=12.0), "first"),
        track.SessionAnalysis(5, write_analysis(tmp_path / "a2", AnalysisStatus.unscaled)),
        track.SessionAnalysis(9, tmp_path / "never-analysed"),
        track.SessionAnalysis(16, write_analysis(tmp_path / "a4", AnalysisStatus.ok, moved_limb, area=6.0)),
    ]
    out = tmp_path / "track"
    result = msgspec.json.decode(track.run(CONF, visits, out).read_bytes(), type=TrackResult)
    s = result.sessions
    assert [v.status for v in s] == ["failed", "ok", "unscaled", "missing", "ok"]
    assert [v.baseline for v in s] == [False, True, False, False, False] and s[1].label == "first"
    assert s[0].area_cm2 is None and s[0].reason.startswith("analysis failed")
    assert "unscaled" in s[2].reason and "neither registered nor compared" in s[2].reason
    assert s[2].area_cm2 is None and s[2].registration_rmse_mm is None and "no analysis.json" in s[3].reason
    assert s[1].registration_rmse_mm == 0 and s[1].area_change_percent == 0
    assert s[4].area_change_cm2 == pytest.approx(-6.0) and s[4].area_change_percent == pytest.approx(-50.0)
    assert s[4].registration_rmse_mm < 0.1 and s[4].registration_warning == ""
    truth = np.linalg.inv(motion(155.0, (12.0, -7.0)))
    skin = moved_limb.surface.vertices[~moved_limb.surface.burn & (moved_limb.surface.vertices[:, 2] > 4)]
    assert rms_apart(np.array(s[4].transform_to_baseline), truth, skin[::50]) < 0.5
    assert result.healing_rate_cm2_per_day == pytest.approx(6.0 / 14, abs=1e-4) and result.projected_closure_day is None
    assert "baseline is visit 2" in result.notes[0]
    doc = json.loads((out / track.RESULT).read_text())
    assert (
        {"day", "area_cm2", "relief_max_mm", "volume_cm3", "registration_rmse_mm", "area_change_percent"}
        <= set(doc["sessions"][0])
        and "healing_rate_cm2_per_day" in doc
        and "projected_closure_day" in doc
    )


def test_track_registers_each_visit_once_and_only_the_new_one_on_a_rerun(tmp_path, baseline_limb, moved_limb):
    base = write_analysis(tmp_path / "a0", AnalysisStatus.ok, baseline_limb, area=12.0)
    second = write_analysis(tmp_path / "a1", AnalysisStatus.ok, moved_limb, area=9.0)
    out = tmp_path / "track"
    track.run(CONF, [track.SessionAnalysis(0, base), track.SessionAnalysis(7, second)], out)
    cached = {p.name: p.stat().st_mtime_ns for p in (out / track.CACHE).iterdir()}
    assert len(cached) == 1
    third = write_analysis(tmp_path / "a2", AnalysisStatus.ok, synthetic_surface(-30.0, (-8.0, 4.0), 8.0), area=6.0)
    visits = [track.SessionAnalysis(0, base), track.SessionAnalysis(7, second), track.SessionAnalysis(14, third)]
    result = msgspec.json.decode(track.run(CONF, visits, out).read_bytes(), type=TrackResult)
    after = {p.name: p.stat().st_mtime_ns for p in (out / track.CACHE).iterdir()}
    assert len(after) == 2 and all(after[name] == stamp for name, stamp in cached.items())
    assert result.projected_closure_day == pytest.approx(28.0, abs=0.1)
    other = msgspec.structs.replace(CONF, burn_margin_mm=6.0)  # a registration setting: registered afresh
    assert track.cache_key(other, base, second) != track.cache_key(CONF, base, second)
    healing_only = msgspec.structs.replace(CONF, stall_after_days=21.0)
    assert track.cache_key(healing_only, base, second) == track.cache_key(CONF, base, second)


def test_track_refuses_visits_out_of_time_order(tmp_path):
    with pytest.raises(InvalidInput, match="time order"):
        track.run(CONF, [track.SessionAnalysis(7, tmp_path / "a"), track.SessionAnalysis(3, tmp_path / "b")], tmp_path)
    with pytest.raises(InvalidInput, match="no visits"):
        track.run(CONF, [], tmp_path)


def test_cli_track_refuses_bad_days_and_missing_folders_before_analysing(tmp_path, capsys):
    a, b, out = tmp_path / "a", tmp_path / "b", str(tmp_path / "out")
    a.mkdir()
    b.mkdir()
    for days, code, message in (
        ("0,7,14", 2, "3 days for 2 visit folders"),
        ("7,0", 2, "must not decrease"),
        ("0,seven", 2, "numbers separated by commas"),
        ("-1,3", 2, "must be 0 or more"),
    ):
        assert cli_main(["track", str(a), str(b), f"--days={days}", "--out", out]) == code
        assert message in capsys.readouterr().err
    assert cli_main(["track", str(a), str(tmp_path / "nowhere"), "--days", "0,7", "--out", out]) == 3
    assert "nowhere is not a folder" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


# --- end to end on a small rendered series -----------------------------------------------------------------------


@pytest.fixture(scope="module")
def rendered_series(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("series")
    run_series(PhantomSpec(seed=11, views=8, width=960, height=720), out)
    return out


def test_cli_track_on_a_rendered_series_meets_the_registration_and_area_change_goals(rendered_series, tmp_path):
    series = json.loads((rendered_series / "ground_truth.json").read_text())
    folders = [str(rendered_series / s["dir"]) for s in series["sessions"]]
    days = ",".join(str(s["day"]) for s in series["sessions"])
    r = cli("track", *folders, "--days", days, "--out", str(tmp_path))
    assert r.returncode == 0, r.stderr[-3000:]
    result = msgspec.json.decode(r.stdout, type=TrackResult)
    truths = [json.loads((rendered_series / s["dir"] / "ground_truth.json").read_text()) for s in series["sessions"]]
    analyses = [Path(s.analysis) for s in result.sessions]
    frames = [to_world(a, t)[0] for a, t in zip(analyses, truths, strict=True)]
    assert result.sessions[0].baseline
    for i in range(1, len(frames)):
        entry, row, analysis, frame = series["sessions"][i], result.sessions[i], analyses[i], frames[i]
        true_change = 100 * (entry["area_ratio_vs_day0"] - 1)
        assert abs(row.area_change_percent - true_change) <= 3.0, (entry["dir"], row.area_change_percent, true_change)
        truth = np.linalg.inv(frames[0]) @ np.linalg.inv(np.array(entry["world_day0_to_world_this"])) @ frame
        follow = registration.load_surface(analysis / track.SURFACE, analysis / track.MESH)
        error = rms_apart(np.array(row.transform_to_baseline), truth, eval_skin(follow, frame))
        assert error <= 1.0, (entry["dir"], error)
        assert row.registration_warning == "" and row.registration_rmse_mm < CONF.max_rmse_mm
    true_rate = -np.polyfit(
        [s["day"] for s in series["sessions"]], [s["burn_area_cm2"] for s in series["sessions"]], 1
    )[0]
    assert result.healing_rate_cm2_per_day == pytest.approx(true_rate, rel=0.1)
    assert result.projected_closure_day is not None and [f.evaluable for f in result.stall_flags] == [
        False,
        True,
        False,
    ]
