"""The report's drawings on real fpdf2 pages, rasterised by poppler's pdftoppm, and the burn-surface renderer on a
small mesh written as the analysis writes it."""

from __future__ import annotations

import shutil
import subprocess
from collections import Counter
from pathlib import Path

import cv2
import numpy as np
import pytest
from fpdf import FPDF

from processing.report import body_diagram, fonts, plots
from processing.report.body_diagram import DEPTH_FILL, REGION_POLYGONS, REGION_VIEW, draw_body_chart, region_point
from processing.report.surface_render import render_surface, write_png
from schemas.burn_chart import BurnDepth, LundBrowderRegion
from schemas.errors import InvalidInput

DPI = 150
needs_poppler = pytest.mark.skipif(shutil.which("pdftoppm") is None, reason="pdftoppm (poppler-utils) not installed")


def _page() -> FPDF:
    pdf = FPDF(unit="mm", format="A4")
    fonts.add_fonts(pdf)
    pdf.add_page()
    pdf.set_font(fonts.FAMILY, size=9)
    return pdf


def _raster(pdf: FPDF, tmp_path: Path) -> np.ndarray:
    """The first page as RGB pixels at DPI."""
    (tmp_path / "page.pdf").write_bytes(bytes(pdf.output()))
    subprocess.run(
        [
            "pdftoppm",
            "-r",
            str(DPI),
            "-png",
            "-singlefile",
            "-f",
            "1",
            "-l",
            "1",
            str(tmp_path / "page.pdf"),
            str(tmp_path / "page"),
        ],
        check=True,
    )
    return cv2.cvtColor(cv2.imread(str(tmp_path / "page.png")), cv2.COLOR_BGR2RGB)


def _px(mm: float) -> int:
    return int(round(mm / 25.4 * DPI))


def _colour_at(image: np.ndarray, x_mm: float, y_mm: float, r: int = 4) -> tuple[int, ...]:
    """The commonest colour in a small patch (a hatch line may cross the exact point)."""
    patch = image[_px(y_mm) - r : _px(y_mm) + r + 1, _px(x_mm) - r : _px(x_mm) + r + 1].reshape(-1, 3)
    return Counter(map(tuple, patch.tolist())).most_common(1)[0][0]


def test_every_region_has_its_own_polygon_in_the_right_view():
    assert set(REGION_POLYGONS) == set(LundBrowderRegion)
    for region, poly in REGION_POLYGONS.items():
        assert len(poly) >= 3 and all(0 <= x <= 1 and 0 <= y <= 1 for x, y in poly), region
        back = region.endswith("_posterior") or region.startswith("buttock") or region.endswith("plantar")
        back = back or region.startswith("hand_") and region.endswith("dorsal")
        assert REGION_VIEW[region] == (body_diagram.BACK if back else body_diagram.FRONT), region
    for region, poly in REGION_POLYGONS.items():  # no two regions of a view cover the same spot
        point = body_diagram._inner_point(poly)
        others = [r for r in REGION_POLYGONS if r != region and REGION_VIEW[r] == REGION_VIEW[region]]
        assert not [r for r in others if body_diagram._inside(*point, REGION_POLYGONS[r])], region


def test_depth_fills_get_darker_with_depth_so_greyscale_copies_keep_the_order():
    grey = [np.dot(DEPTH_FILL[d], [0.299, 0.587, 0.114]) for d in BurnDepth]
    assert all(a - b > 35 for a, b in zip(grey, grey[1:], strict=False)), grey


@needs_poppler
def test_body_chart_fills_charted_regions_with_their_depth_colour(tmp_path):
    shading = {
        LundBrowderRegion.trunk_anterior: BurnDepth.superficial_partial,
        LundBrowderRegion.buttock_left: BurnDepth.full_thickness,
        LundBrowderRegion.hand_right_palmar: BurnDepth.deep_partial,
        LundBrowderRegion.head_anterior: BurnDepth.superficial,
    }
    pdf = _page()
    box = (14, 20, 113, 92)
    draw_body_chart(pdf, *box, shading)
    image = _raster(pdf, tmp_path)
    for region, depth in shading.items():
        colour = _colour_at(image, *region_point(region, *box))
        assert np.abs(np.subtract(colour, DEPTH_FILL[depth])).max() <= 6, (region, colour)
    for region in (LundBrowderRegion.thigh_left_anterior, LundBrowderRegion.buttock_right):
        assert min(_colour_at(image, *region_point(region, *box))) >= 250, region
    # The patient's right is on the reader's left in the front view, on the reader's right in the back view.
    front_mid = region_point(LundBrowderRegion.trunk_anterior, *box)[0]
    back_mid = region_point(LundBrowderRegion.trunk_posterior, *box)[0]
    assert region_point(LundBrowderRegion.hand_right_palmar, *box)[0] < front_mid
    assert region_point(LundBrowderRegion.buttock_right, *box)[0] > back_mid
    assert region_point(LundBrowderRegion.hand_left_dorsal, *box)[0] < back_mid


@needs_poppler
@pytest.mark.parametrize("n", [0, 1, 4])
def test_line_plot_draws_the_points_it_is_given(tmp_path, n):
    points = [(2.0, 41.3), (6.0, 33.0), (10.0, 24.8), (15.0, 14.1)][:n]
    pdf = _page()
    plots.line_plot(
        pdf,
        20,
        20,
        90,
        55,
        points=points,
        title="Burn area",
        y_label="area (cm²)",
        fit=(45.2, -2.1) if n > 1 else None,
        marks=[(21.0, "Deitch 21 d")],
    )
    image = _raster(pdf, tmp_path)
    series = np.all(np.abs(image.astype(int) - plots.SERIES) <= 8, axis=2)
    blobs = cv2.connectedComponents(series.astype(np.uint8))[0] - 1
    assert blobs == (0 if n == 0 else 1)  # markers joined by the line make one shape
    if n:
        # the first point lands where the axes say: day 2 of 0..25 (the mark at 21 is in range), 41.3 of 0..50
        left, right, head, foot = 20 + 11.0, 20 + 90 - 2.0, 20 + 5.5, 20 + 55 - 8.5
        ys, xs = np.nonzero(series)
        first = (left + (right - left) * 2 / 25, foot - (foot - head) * 41.3 / 50)
        near = np.hypot(xs - _px(first[0]), ys - _px(first[1])).min()
        assert near <= 3


def test_round_ticks_and_the_fit_clipped_to_the_box():
    assert plots.nice_step(48) == 10 and plots.nice_step(0.42) == 0.1 and plots.nice_step(7) == 2
    assert plots._ticks(41.3 * 1.08)[0] == 50
    x0, y0, x1, y1 = plots._clip_fit((45.2, -2.1), 25, 50)
    assert (x0, y0) == (0, 45.2) and x1 == pytest.approx(45.2 / 2.1) and y1 == pytest.approx(0)
    assert plots._clip_fit((-3.0, -1.0), 25, 50) is None


def test_the_font_prints_diacritics_greek_and_cyrillic_as_text(tmp_path):
    pypdf = pytest.importorskip("pypdf")
    name = "Zoë Ångström-Núñez · Σωκράτης Παπαδόπουλος · Анна Кузнецова"
    pdf = _page()
    pdf.cell(0, 6, name)
    pdf.set_font(fonts.FAMILY, "B", 9)
    pdf.ln(8)
    pdf.cell(0, 6, "Łódź Ωμέγα Ёлка")
    (tmp_path / "fonts.pdf").write_bytes(bytes(pdf.output()))
    text = pypdf.PdfReader(tmp_path / "fonts.pdf").pages[0].extract_text()
    assert name in text and "Łódź Ωμέγα Ёлка" in text


@pytest.mark.parametrize("damage", ["missing", "altered"])
def test_check_fonts_names_a_missing_or_altered_font(tmp_path, monkeypatch, damage):
    folder = tmp_path / "fonts"
    shutil.copytree(fonts.FOLDER, folder)
    bold = folder / fonts.FILES["B"]
    if damage == "missing":
        bold.unlink()
    else:
        data = bytearray(bold.read_bytes())
        data[len(data) // 2] ^= 0xFF
        bold.write_bytes(bytes(data))
    monkeypatch.setattr(fonts, "FOLDER", folder)
    fonts.check_fonts.cache_clear()
    try:
        with pytest.raises(InvalidInput, match=fonts.FILES["B"]):
            fonts.check_fonts()
    finally:
        fonts.check_fonts.cache_clear()


SKIN = np.array([0.80, 0.62, 0.50])


def _write_analysis(folder: Path, *, flip_winding: bool) -> None:
    """A flat 60 x 60 mm patch in z = 0 seen from +z (as the output frame puts the cameras), written as the
    analysis folder holds it: surface/burn_surface.npz and mesh/surface.ply. The burn is a disc of radius 10 mm
    at (10, 5) with its upper right quarter healthy, so a mirrored or upside-down picture shows."""
    import open3d as o3d

    n = 121
    gx, gy = np.meshgrid(np.linspace(-30, 30, n), np.linspace(-30, 30, n))
    vertices = np.stack([gx.ravel(), gy.ravel(), np.zeros(n * n)], 1)
    i = (np.arange(n - 1)[:, None] * n + np.arange(n - 1)[None]).ravel()
    faces = np.concatenate([np.stack([i, i + 1, i + n + 1], 1), np.stack([i, i + n + 1, i + n], 1)])
    faces = faces[:, ::-1] if flip_winding else faces
    x, y = vertices[:, 0], vertices[:, 1]
    burn = (np.hypot(x - 10, y - 5) <= 10) & ~((x > 12) & (y > 7))
    q = np.where(burn, 0.95, 0.05)
    q[np.hypot(x, y) > 28] = np.nan  # outside the region looked at: neither burn nor healthy
    (folder / "surface").mkdir(parents=True)
    (folder / "mesh").mkdir()
    np.savez_compressed(
        folder / "surface" / "burn_surface.npz",
        vertices=vertices,
        faces=faces,
        q=q,
        views_per_vertex=np.full(len(q), 3),
        view_sees_burn=np.ones(3, bool),
        view_names=np.array(["a.jpg", "b.jpg", "c.jpg"]),
        q_noisy_or=q,
    )
    mesh = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(vertices), o3d.utility.Vector3iVector(faces))
    mesh.vertex_colors = o3d.utility.Vector3dVector(np.tile(SKIN, (len(vertices), 1)))
    mesh.vertex_normals = o3d.utility.Vector3dVector(np.tile([0.0, 0.0, 1.0], (len(vertices), 1)))
    o3d.io.write_triangle_mesh(str(folder / "mesh" / "surface.ply"), mesh)


@pytest.mark.parametrize("flip_winding", [False, True])
def test_render_surface_paints_the_burn_where_it_is(tmp_path, flip_winding):
    _write_analysis(tmp_path, flip_winding=flip_winding)
    npz = tmp_path / "surface" / "burn_surface.npz"
    image = render_surface(npz, 450, 350, scaled=True)
    assert image.shape == (350, 450, 3) and image.dtype == np.uint8
    write_png(image, tmp_path / "surface.png")
    rgb = image.astype(int)
    magenta = (rgb[..., 0] - rgb[..., 1] > 60) & (rgb[..., 2] - rgb[..., 1] > 40)
    ys, xs = np.nonzero(magenta)
    assert magenta.sum() > 2000
    # Map mm to pixels from the painted disc's extent (x 0..20 mm, y -5..15 mm; y up in the picture).
    sx = (xs.max() - xs.min()) / 20
    to_px = lambda x, y: (int(xs.min() + x * sx), int(ys.max() - (y + 5) * sx))  # noqa: E731
    for x, y in [(6, 6), (10, 0), (16, 2)]:
        assert magenta[to_px(x, y)[::-1]], (x, y)
    healthy_corner = to_px(16.5, 10.5)
    assert not magenta[healthy_corner[::-1]]
    skin = rgb[healthy_corner[1], healthy_corner[0]] / 255
    assert np.allclose(skin / skin.max(), SKIN / SKIN.max(), atol=0.06)  # Lambert-shaded skin, not paint
    dark = rgb.max(axis=2) < 60
    assert dark[to_px(10, 15.0)[1] - 3 : to_px(10, 15.0)[1] + 4, to_px(10, 15.0)[0]].any()  # outline at the top
    assert dark[-60:, :120].sum() > 200  # the scale bar
    unscaled = render_surface(npz, 450, 350, scaled=False)
    assert (unscaled.astype(int).max(axis=2) < 60)[-60:, :120].sum() < 20


def test_render_surface_names_an_unreadable_file(tmp_path):
    (tmp_path / "burn_surface.npz").write_bytes(b"not an npz")
    with pytest.raises(InvalidInput, match="burn_surface.npz"):
        render_surface(tmp_path / "burn_surface.npz")
