"""Burn geometry on hand-computable surfaces: sampling with visibility, fusion, area, perimeter, relief."""

from __future__ import annotations

import math

import numpy as np
import pytest

from processing.analysis import burn_region as br
from processing.analysis import fusion, projection, relief, surface_map
from schemas.errors import InvalidInput
from tests import surface_shapes as ss

EDGE_MM = 1.5
"""Blur of the rendered burn edge (Gaussian sigma on the surface, ~3 px in the pictures)."""


@pytest.fixture(scope="module")
def views():
    return ss.cone_views()


def _fused(mesh: ss.Surface, views, maps, rule: str = "log_odds") -> np.ndarray:
    p, w = projection.sample_views(mesh.vertices, mesh.faces, views, maps)
    return fusion.fuse(rule, p, w)


# --- sub-face splitting -------------------------------------------------------------------------------------

TRIANGLE = np.array([[0.0, 0.0, 0.0], [4.0, 0.0, 0.0], [0.0, 3.0, 0.0]])  # area 6


@pytest.mark.parametrize(
    ("q", "fraction"),
    [
        ((1, 0, 0), 0.25),
        ((1, 1, 0), 0.75),
        ((0, 1, 1), 0.75),
        ((1, 1, 1), 1.0),
        ((0, 0, 0), 0.0),
        ((1, np.nan, 0), 0.25),
        ((0.9, 0.1, 0.5), 0.5),
    ],
)
def test_single_triangle_is_clipped_at_the_level_line(q, fraction):
    faces = np.array([[0, 1, 2]])
    q = np.array(q, dtype=float)
    assert br.burn_area_mm2(TRIANGLE, faces, q) == pytest.approx(6.0 * fraction, abs=1e-12)
    assert br.per_face_burn_fraction(TRIANGLE, faces, q)[0] == pytest.approx(fraction, abs=1e-12)


def test_boundary_segment_of_one_triangle_joins_the_edge_midpoints():
    segments = br.boundary_segments(TRIANGLE, np.array([[0, 1, 2]]), np.array([1.0, 0.0, 0.0]))
    assert segments.shape == (1, 2, 3)
    np.testing.assert_allclose(segments[0], [[2.0, 0.0, 0.0], [0.0, 1.5, 0.0]])


def test_area_fraction_paints_faces_and_sums_to_the_area():
    mesh = ss.sheet(half=10.0, step=2.0)
    q = np.clip(0.5 + (3.3 - mesh.vertices[:, 0]) / 10.0, 0, 1)  # burnt where x <= 3.3: a 13.3 x 20 strip
    fraction = br.per_face_burn_fraction(mesh.vertices, mesh.faces, q)
    areas = br.triangle_areas(mesh.vertices[mesh.faces])
    assert br.burn_area_mm2(mesh.vertices, mesh.faces, q) == pytest.approx(13.3 * 20.0, rel=1e-9)
    assert float(fraction @ areas) == pytest.approx(13.3 * 20.0, rel=1e-9)
    # The level line x = 3.3 cuts the column of cells 2 <= x <= 4 at 0.65 of its width: lower-right triangles
    # keep 0.65² of their area, upper-left ones 1 - 0.35².
    np.testing.assert_allclose(np.unique(np.round(fraction, 9)), [0.0, 0.65**2, 1 - 0.35**2, 1.0])


# --- fusion -------------------------------------------------------------------------------------------------


def test_noisy_or_saturates_while_means_stay_put():
    rng = np.random.default_rng(1)
    p = np.full((10, 3), 0.2)
    w = rng.uniform(0.2, 1.0, size=(10, 3))
    w[:, 2] = 0.0  # vertex 2 is seen by no view
    w[5:, 1] = 0.0  # vertex 1 by five
    no = fusion.fuse(fusion.FusionRule.noisy_or, p, w)
    assert no[0] == pytest.approx(1 - 0.8**10) and no[0] > 0.89
    assert no[1] == pytest.approx(1 - 0.8**5)
    for rule in ("weighted_mean", "log_odds"):
        fused = fusion.fuse(rule, p, w)
        np.testing.assert_allclose(fused[:2], 0.2)
        assert np.isnan(fused[2])
    assert np.isnan(no[2])
    np.testing.assert_array_equal(fusion.views_per_vertex(w), [10, 5, 0])


def test_weighted_rules_follow_the_weights():
    p = np.array([[0.9], [0.1]])
    w = np.array([[3.0], [1.0]])
    assert fusion.weighted_mean(p, w)[0] == pytest.approx(0.7)
    logit = (3 * math.log(9) + math.log(1 / 9)) / 4
    assert fusion.log_odds(p, w)[0] == pytest.approx(1 / (1 + math.exp(-logit)))


# --- sampling and visibility --------------------------------------------------------------------------------


def test_sampling_is_bilinear_at_the_projection(views):
    mesh = ss.sheet(half=30.0, step=3.0)
    view = views[0]
    u = np.arange(view.width, dtype=np.float32)
    prob = np.tile(u / (view.width - 1), (view.height, 1))
    sample = projection.sample_view(
        mesh.vertices, mesh.faces, projection.vertex_normals(mesh.vertices, mesh.faces), view, prob
    )
    uv, _ = view.project(mesh.vertices)
    assert sample.seen.all()
    np.testing.assert_allclose(sample.p, uv[:, 0] / (view.width - 1), atol=1e-6)
    cos = (view.centre - mesh.vertices)[:, 2] / np.linalg.norm(view.centre - mesh.vertices, axis=1)
    np.testing.assert_allclose(sample.weight, cos, atol=1e-9)


def test_a_vertex_behind_another_surface_is_not_seen():
    lower, upper = ss.sheet(half=30.0, step=2.0), ss.sheet(half=15.0, step=2.0)
    vertices = np.vstack([lower.vertices, upper.vertices + [0.0, 0.0, 20.0]])
    faces = np.vstack([lower.faces, upper.faces + len(lower.vertices)])
    view = ss.look_at("top", np.array([0.0, 0.0, 270.0]), np.zeros(3))
    sample = projection.sample_view(
        vertices,
        faces,
        projection.vertex_normals(vertices, faces),
        view,
        np.ones((view.height, view.width), np.float32),
    )
    n = len(lower.vertices)
    # The ray to (x, y, 0) crosses z = 20 at (x, y) * 250/270, inside the upper sheet while max|x|,|y| < 16.2.
    reach = np.abs(lower.vertices[:, :2]).max(axis=1)
    assert not sample.seen[:n][reach <= 16].any()
    assert sample.seen[:n][reach >= 18].all()
    assert sample.seen[n:].all()
    np.testing.assert_array_equal(sample.p[~sample.seen], 0.0)
    np.testing.assert_array_equal(sample.weight[~sample.seen], 0.0)


def test_back_faces_and_vertices_outside_the_picture_are_not_seen():
    mesh = ss.sheet(half=200.0, step=10.0)
    normals = projection.vertex_normals(mesh.vertices, mesh.faces)
    prob = np.ones((ss.H, ss.W), np.float32)
    below = ss.look_at("below", np.array([0.0, 0.0, -270.0]), np.zeros(3))
    assert not projection.sample_view(mesh.vertices, mesh.faces, normals, below, prob).seen.any()
    above = ss.look_at("above", np.array([0.0, 0.0, 270.0]), np.zeros(3))
    seen = projection.sample_view(mesh.vertices, mesh.faces, normals, above, prob).seen
    half_width = (ss.W - 1) / 2 / ss.F * 270.0  # 143.6 mm across, 107.6 mm up and down
    x, y = np.abs(mesh.vertices[:, 0]), np.abs(mesh.vertices[:, 1])
    np.testing.assert_array_equal(seen, (x < half_width - 1) & (y < half_width * (ss.H - 1) / (ss.W - 1) - 1))


# --- area and perimeter on rendered scenes ------------------------------------------------------------------


@pytest.mark.parametrize(("radius", "half", "step"), [(20.0, 50.0, 1.0), (20.0, 50.0, 2.5), (40.0, 70.0, 5.0)])
def test_flat_disc_area_and_perimeter(views, radius, half, step):
    plane = ss.sheet(half=half + 10, step=2 * half + 20)  # two triangles render a plane exactly
    maps = ss.render_views(plane, views, ss.disc_probability(plane.chart_of, radius, EDGE_MM))
    mesh = ss.sheet(half=half, step=step)
    q = _fused(mesh, views, maps)
    assert br.burn_area_mm2(mesh.vertices, mesh.faces, q) == pytest.approx(math.pi * radius**2, rel=0.01)
    loops = br.boundary_loops(mesh.vertices, mesh.faces, q)
    assert [loop.closed for loop in loops] == [True]
    perimeter = br.perimeter_mm(loops)
    assert perimeter.perimeter_mm == pytest.approx(2 * math.pi * radius, rel=0.02)
    assert (perimeter.n_loops, perimeter.n_small_loops) == (1, 0)
    assert perimeter.largest_loop_mm == perimeter.perimeter_mm
    # The seed's rule grows the burn: the soft edge seen by six views reads as burnt well outside the circle.
    q_or = _fused(mesh, views, maps, "noisy_or")
    assert br.burn_area_mm2(mesh.vertices, mesh.faces, q_or) > 1.1 * math.pi * radius**2


def test_disc_on_a_cylinder_keeps_its_flat_area(views):
    radius = 20.0
    render_mesh = ss.cylinder(step=0.5)
    maps = ss.render_views(render_mesh, views, ss.disc_probability(render_mesh.chart_of, radius, EDGE_MM))
    mesh = ss.cylinder(step=1.0)
    q = _fused(mesh, views, maps)
    assert br.burn_area_mm2(mesh.vertices, mesh.faces, q) == pytest.approx(math.pi * radius**2, rel=0.02)
    perimeter = br.perimeter_mm(br.boundary_loops(mesh.vertices, mesh.faces, q))
    assert perimeter.perimeter_mm == pytest.approx(2 * math.pi * radius, rel=0.02)


def test_spherical_cap_area(views):
    sphere_r, geodesic_r = 60.0, 20.0
    render_mesh = ss.sphere_cap(radius=sphere_r, step=0.5)
    maps = ss.render_views(render_mesh, views, ss.disc_probability(render_mesh.chart_of, geodesic_r, EDGE_MM))
    mesh = ss.sphere_cap(radius=sphere_r, step=1.0)
    q = _fused(mesh, views, maps)
    h = sphere_r * (1 - math.cos(geodesic_r / sphere_r))
    assert br.burn_area_mm2(mesh.vertices, mesh.faces, q) == pytest.approx(2 * math.pi * sphere_r * h, rel=0.02)


def test_separate_patches_and_specks_are_separate_loops():
    mesh = ss.sheet(half=40.0, step=1.0)
    x, y = mesh.vertices[:, 0], mesh.vertices[:, 1]
    big = np.hypot(x + 15, y) <= 15.0
    speck = np.hypot(x - 25, y - 25) <= 0.8  # one vertex: a ~1 mm² speck
    edge = x >= 38.5  # runs off the mesh: an open boundary line
    q = (big | speck | edge).astype(float)
    loops = br.boundary_loops(mesh.vertices, mesh.faces, q)
    assert sorted(loop.closed for loop in loops) == [False, True, True]
    perimeter = br.perimeter_mm(loops)
    assert (perimeter.n_loops, perimeter.n_small_loops) == (2, 1)
    assert perimeter.largest_loop_mm == pytest.approx(2 * math.pi * 15.0, rel=0.05)
    assert perimeter.small_loops_mm < 5.0
    open_loop = next(loop for loop in loops if not loop.closed)
    assert br.perimeter_mm([open_loop]).perimeter_mm == pytest.approx(80.0, abs=0.5)


# --- relief -------------------------------------------------------------------------------------------------

DEPTH, CRATER_R = 3.0, 20.0


def test_crater_relief(views):
    mesh = ss.sheet(half=50.0, step=1.0, height=lambda x, y: ss.crater(DEPTH, CRATER_R, x, y))
    maps = ss.render_views(mesh, views, ss.disc_probability(mesh.chart_of, CRATER_R, EDGE_MM))
    q = _fused(mesh, views, maps)
    centre = np.zeros(3)
    reference = relief.fit_reference(mesh.vertices, mesh.faces, q, relief.outward_from_views(views, centre))
    assert reference.kind == "quartic"
    assert reference.ring_rms_mm < 0.01
    np.testing.assert_allclose(reference.axes[2], [0, 0, 1], atol=1e-6)
    result = relief.relief(mesh.vertices, mesh.faces, q, reference)
    assert result.max_mm == pytest.approx(DEPTH, abs=0.2)
    assert result.volume_mm3 == pytest.approx(math.pi * CRATER_R**2 * DEPTH / 3, rel=0.10)
    assert result.mean_mm == pytest.approx(DEPTH / 3, rel=0.10)
    assert abs(result.raised_max_mm) < 0.05
    # The crater's walls add area; the burn, drawn by its flat footprint, still covers ~pi r².
    assert result.area_mm2 == pytest.approx(math.pi * CRATER_R**2, rel=0.02)


def test_quadratic_reference_recovers_depth_on_curved_skin():
    # Healthy skin curving away like a forearm (radius ~60 mm across x), a 3 mm crater in it.
    mesh = ss.sheet(half=50.0, step=1.0, height=lambda x, y: -x * x / 120.0 + ss.crater(DEPTH, CRATER_R, x, y))
    q = ss.disc_probability(mesh.chart_of, CRATER_R, EDGE_MM)(mesh.vertices)
    outward = np.array([0.0, 0.0, 1.0])
    quadratic = relief.fit_reference(mesh.vertices, mesh.faces, q, outward, kind="quadratic")
    plane = relief.fit_reference(mesh.vertices, mesh.faces, q, outward, kind="plane")
    assert quadratic.ring_rms_mm < 0.05
    assert plane.ring_rms_mm > 1.0
    assert relief.relief(mesh.vertices, mesh.faces, q, quadratic).max_mm == pytest.approx(DEPTH, abs=0.2)
    assert relief.relief(mesh.vertices, mesh.faces, q, plane).max_mm < DEPTH - 1.0


def test_quartic_and_ridged_references_follow_a_round_limb_where_a_parabola_cannot():
    # A forearm-like circular cylinder of radius 40 mm: over a ring reaching 35 mm from the burn centre a
    # parabola misses the circle by tenths of a mm, which would bias the relief and the volume. A quartic follows
    # it; so does a ridged model (a cylinder is one long ridge), which "auto" may prefer.
    radius = 40.0
    mesh = ss.sheet(
        half=37.0, step=1.0, height=lambda x, y: np.sqrt(radius**2 - x * x) - radius + ss.crater(DEPTH, CRATER_R, x, y)
    )
    q = ss.disc_probability(mesh.chart_of, CRATER_R, EDGE_MM)(mesh.vertices)
    outward = np.array([0.0, 0.0, 1.0])
    auto = relief.fit_reference(mesh.vertices, mesh.faces, q, outward)
    quartic = relief.fit_reference(mesh.vertices, mesh.faces, q, outward, kind="quartic")
    quadratic = relief.fit_reference(mesh.vertices, mesh.faces, q, outward, kind="quadratic")
    assert auto.kind in ("quartic", "ridged")
    assert max(auto.ring_rms_mm, quartic.ring_rms_mm) < quadratic.ring_rms_mm / 3
    biased = relief.relief(mesh.vertices, mesh.faces, q, quadratic)
    for reference in (auto, quartic):
        good = relief.relief(mesh.vertices, mesh.faces, q, reference)
        assert good.max_mm == pytest.approx(DEPTH, abs=0.1)
        assert abs(good.mean_mm - DEPTH / 3) < abs(biased.mean_mm - DEPTH / 3)


def _ridges(x: np.ndarray, y: np.ndarray, angle_deg: float = 30.0) -> np.ndarray:
    """Parallel ridges +-1 mm high, 12 mm apart, running at angle_deg to x (tendons over the back of a foot)."""
    a = math.radians(angle_deg)
    return np.sin(2 * math.pi * (-math.sin(a) * x + math.cos(a) * y) / 12.0 + 0.7)


def test_ridged_reference_carries_ridges_under_the_burn_where_a_quartic_cannot():
    mesh = ss.sheet(half=45.0, step=0.8, height=lambda x, y: _ridges(x, y) + ss.crater(DEPTH, CRATER_R, x, y))
    q = ss.disc_probability(mesh.chart_of, CRATER_R, EDGE_MM)(mesh.vertices)
    outward = np.array([0.0, 0.0, 1.0])
    auto = relief.fit_reference(mesh.vertices, mesh.faces, q, outward)
    quartic = relief.fit_reference(mesh.vertices, mesh.faces, q, outward, kind="quartic")
    assert auto.kind == "ridged" and auto.holdout_mm < quartic.holdout_mm / 3
    assert auto.ring_rms_mm < 0.05 < quartic.ring_rms_mm
    found, wrong = (
        relief.relief(mesh.vertices, mesh.faces, q, auto),
        relief.relief(mesh.vertices, mesh.faces, q, quartic),
    )
    assert found.max_mm == pytest.approx(DEPTH, abs=0.2)
    assert found.volume_mm3 == pytest.approx(math.pi * CRATER_R**2 * DEPTH / 3, rel=0.10)
    assert abs(wrong.max_mm - DEPTH) > 0.5


def test_uneven_skin_is_flagged_and_ridges_are_not_believed_where_they_explain_nothing():
    rng = np.random.default_rng(11)
    lumps = [
        (*rng.uniform(-40, 40, 2), rng.choice([-1, 1]) * rng.uniform(1.0, 2.0), rng.uniform(3, 5)) for _ in range(60)
    ]

    def lumpy(x, y):
        return sum(a * np.exp(-((x - cx) ** 2 + (y - cy) ** 2) / (2 * s**2)) for cx, cy, a, s in lumps)

    mesh = ss.sheet(half=45.0, step=0.8, height=lambda x, y: lumpy(x, y) + ss.crater(DEPTH, CRATER_R, x, y))
    q = ss.disc_probability(mesh.chart_of, CRATER_R, EDGE_MM)(mesh.vertices)
    reference = relief.fit_reference(mesh.vertices, mesh.faces, q, np.array([0.0, 0.0, 1.0]))
    assert reference.kind == "quartic" and reference.holdout_mm > relief.UNCERTAIN_REFERENCE_MM
    coarse = ss.sheet(half=12.0, step=6.0)
    small = (np.abs(coarse.vertices[:, :2]).max(axis=1) < 1).astype(float)
    with pytest.raises(InvalidInput, match="ridged reference needs at least 100 ring points"):
        relief.fit_reference(coarse.vertices, coarse.faces, small, np.array([0.0, 0.0, 1.0]), kind="ridged")


def _blister(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """A dome standing 0.75 mm proud over a 10 mm radius."""
    return -ss.crater(0.75, 10.0, x, y)


def test_raised_blister_and_outliers_in_the_ring():
    mesh = ss.sheet(half=40.0, step=1.0, height=_blister)
    rng = np.random.default_rng(3)
    rho = np.hypot(mesh.vertices[:, 0], mesh.vertices[:, 1])
    ring = np.flatnonzero((rho > 14) & (rho < 24))
    hair = rng.choice(ring, len(ring) // 7, replace=False)
    mesh.vertices[hair, 2] += 4.0  # tall outliers on 1 in 7 ring vertices (hair, a dressing edge)
    q = ss.disc_probability(mesh.chart_of, 10.0, EDGE_MM)(mesh.vertices)
    reference = relief.fit_reference(mesh.vertices, mesh.faces, q, np.array([0.0, 0.0, 1.0]))
    result = relief.relief(mesh.vertices, mesh.faces, q, reference)
    assert result.raised_max_mm == pytest.approx(0.75, abs=0.1)
    assert result.max_mm < 0.1 and result.volume_mm3 < 1.0


def test_one_sided_or_thin_ring_falls_back_to_a_plane():
    mesh = ss.sheet(half=30.0, step=1.0)
    q = (mesh.vertices[:, 0] > 20).astype(float)  # burn along the mesh border: ring on one side only
    one_sided = relief.fit_reference(mesh.vertices, mesh.faces, q, np.array([0.0, 0.0, 1.0]))
    assert one_sided.kind == "plane"
    coarse = ss.sheet(half=12.0, step=6.0)
    q = (np.abs(coarse.vertices[:, :2]).max(axis=1) < 1).astype(float)
    thin = relief.fit_reference(coarse.vertices, coarse.faces, q, np.array([0.0, 0.0, 1.0]))
    assert thin.kind == "plane" and thin.ring_size < relief.MIN_RING_QUADRATIC


# --- bad input ----------------------------------------------------------------------------------------------


def test_bad_input_is_refused_with_a_reason(views):
    mesh = ss.sheet(half=10.0, step=5.0)
    normals = projection.vertex_normals(mesh.vertices, mesh.faces)
    with pytest.raises(InvalidInput, match=r"shape \(3, 4\), expected \(480, 640\)"):
        projection.sample_view(mesh.vertices, mesh.faces, normals, views[0], np.zeros((3, 4)))
    with pytest.raises(InvalidInput, match="one value per vertex"):
        br.burn_area_mm2(mesh.vertices, mesh.faces, np.zeros(3))
    with pytest.raises(InvalidInput, match="faces index vertices outside"):
        br.burn_area_mm2(mesh.vertices, mesh.faces + 100, np.zeros(len(mesh.vertices)))
    with pytest.raises(InvalidInput, match="p and w must both have shape"):
        fusion.fuse("log_odds", np.zeros((2, 5)), np.zeros((3, 5)))
    with pytest.raises(InvalidInput, match="unknown fusion rule"):
        fusion.fuse("max", np.zeros((2, 5)), np.zeros((2, 5)))
    with pytest.raises(InvalidInput, match="no mesh vertex is seen"):
        projection.sample_views(mesh.vertices + [0, 0, 1000.0], mesh.faces, views[:1], [np.zeros((480, 640))])
    with pytest.raises(InvalidInput, match="no edge"):
        relief.fit_reference(mesh.vertices, mesh.faces, np.zeros(len(mesh.vertices)), np.array([0.0, 0.0, 1.0]))


def test_specks_apart_from_the_burn_are_set_aside_but_a_satellite_burn_counts():
    from processing.analysis.surface_map import stray_regions

    mesh = ss.sheet(half=30.0, step=1.0)
    x, y = mesh.vertices[:, 0], mesh.vertices[:, 1]
    main, speck, satellite = np.hypot(x, y) < 10, np.hypot(x - 22, y - 22) < 2, np.hypot(x + 20, y - 20) < 6
    q = np.where(main | speck | satellite, 0.9, 0.1)
    stray = stray_regions(mesh.vertices, mesh.faces, q)
    np.testing.assert_array_equal(stray, speck)
    assert not stray_regions(mesh.vertices, mesh.faces, np.zeros(len(q))).any()


def test_a_few_vertices_over_the_threshold_are_no_burn_found_never_a_burn_of_0_cm2():
    s = ss.sheet(half=45.0, step=1.0)  # a 9 cm square of skin, all looked at
    rho = np.linalg.norm(s.vertices[:, :2], axis=1)
    nothing = np.zeros(len(rho))
    speck = np.where(rho < 0.5, 0.9, 0.0)  # one vertex over 0.5: its split faces hold a fraction of a mm2
    burn = np.where(rho < 10.0, 0.9, 0.0)  # a 3 cm2 burn
    assert not surface_map.burn_found(s.vertices, s.faces, nothing)
    assert not surface_map.burn_found(s.vertices, s.faces, speck)
    assert surface_map.burn_found(s.vertices, s.faces, burn)
    unseen = burn.copy()
    unseen[rho > 12.0] = np.nan  # only the skin looked at counts: a burn that fills the view is still a burn
    assert surface_map.burn_found(s.vertices, s.faces, unseen)
