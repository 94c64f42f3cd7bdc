"""Stage entry points: render a phantom scene, or a longitudinal series of them, with ground truth.

`run` writes images/, masks/, object_masks/, true_surface.npz and ground_truth.json into a
folder; `run_series` writes one such folder per session (the same limb, moved by a known rigid
transform, with a burn that shrinks and heals, photographed anew) and a top-level
ground_truth.json listing the sessions. Every random choice comes from the spec's seed, one
stream per purpose, so a seed gives the same files.
"""

from __future__ import annotations

import enum
import logging
import math
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import msgspec
import numpy as np

from processing.phantom import drape, skin
from processing.phantom.burn import Burn, random_outline, scaled
from processing.phantom.cameras import intrinsics, sample_cameras
from processing.phantom.ground_truth import burn_figures, encode_json, session_truth, true_surface, write_true_surface
from processing.phantom.marker_strip import choose_ids, strip_texture
from processing.phantom.photo import develop, exif_focal, write_jpeg, write_mask
from processing.phantom.render import render_view
from processing.phantom.scene import build_scene
from processing.phantom.series import SERIES, series_document, session_motion
from processing.phantom.surfaces import Surface, make_surface
from processing.phantom.textures import ChartTexture
from processing.phantom.truth import relative_difference, size_burn
from schemas.errors import InvalidInput
from schemas.phantom import PhantomSpec, PhantomTruth

log = logging.getLogger(__name__)
GENERATOR = "burnedge phantom 1.0"
RENDER_THREADS = 2


class Stream(enum.IntEnum):
    surface = 1
    outline = 2
    skin = 3
    cloth = 4
    marker = 5
    placement = 6
    cameras = 7
    render = 8
    noise = 9
    burn_look = 10
    motion = 11


def stream(spec: PhantomSpec, which: Stream, session: int = 0, view: int = 0) -> np.random.Generator:
    return np.random.default_rng([spec.seed, int(which), session, view])


def validate(spec: PhantomSpec) -> PhantomSpec:
    """The spec with every bound checked (msgspec does not check bounds on construction)."""
    try:
        spec = msgspec.convert(msgspec.to_builtins(spec), PhantomSpec)
    except msgspec.ValidationError as exc:
        raise InvalidInput(f"phantom spec: {exc} (see `burnedge phantom --help` for the ranges)") from exc
    if spec.distance_min_mm >= spec.distance_max_mm:
        raise InvalidInput(
            f"phantom spec: distance_min_mm ({spec.distance_min_mm:g}) must be below "
            f"distance_max_mm ({spec.distance_max_mm:g})"
        )
    if spec.marker_ids is not None and (len(spec.marker_ids) != 3 or len(set(spec.marker_ids)) != 3):
        raise InvalidInput(f"phantom spec: marker_ids must be three different ids from 0 to 49, not {spec.marker_ids}")
    return spec


@dataclass(frozen=True)
class Limb:
    """What stays the same across the sessions of a series."""

    surface: Surface
    burn: Burn
    """The day-0 burn."""
    skin: ChartTexture
    """Skin without the burn."""
    cloth: drape.DrapeCloth
    marker_texture: ChartTexture
    marker_ids: tuple[int, int, int]
    texel_mm: float
    mesh_spacing_mm: float


def place_burn(spec: PhantomSpec, surface: Surface) -> Burn:
    rng = stream(spec, Stream.outline)
    for _ in range(20):
        outline, centre = random_outline(rng), surface.burn_centre(rng)
        try:
            burn = size_burn(surface, Burn(centre, 10.0, outline, spec.depth_mm), spec.area_cm2 * 100.0)
        except InvalidInput:
            continue
        if surface.burn_allowed(*burn.chart_point(np.ones(360), np.linspace(0, 2 * math.pi, 360))).all():
            return burn
    raise InvalidInput(
        f"a burn of {spec.area_cm2:g} cm2 does not fit on top of the {spec.shape.value}: "
        "ask for a smaller area or a larger body part (patch)"
    )


def prepare(spec: PhantomSpec) -> Limb:
    # Texels and render-mesh edges follow the finest ray spacing on the skin (from the nearest camera):
    # full-size renders get 0.1 mm texels, small test renders much cheaper textures.
    k = intrinsics(spec.width, spec.height, spec.hfov_deg)
    ray_footprint_mm = spec.distance_min_mm / (k[0, 0] * spec.supersample)
    texel = max(0.1, ray_footprint_mm)
    surface = make_surface(spec.shape, stream(spec, Stream.surface))
    burn = place_burn(spec, surface)
    ids = (
        (spec.marker_ids[0], spec.marker_ids[1], spec.marker_ids[2])
        if spec.marker_ids
        else choose_ids(stream(spec, Stream.marker))
    )
    return Limb(
        surface=surface,
        burn=burn,
        skin=skin.skin_texture(surface, spec.tone, texel, stream(spec, Stream.skin)),
        cloth=drape.make_cloth(stream(spec, Stream.cloth), 3 * texel),
        marker_texture=strip_texture(ids, stream(spec, Stream.marker, 1)),
        marker_ids=ids,
        texel_mm=texel,
        mesh_spacing_mm=float(np.clip(4 * ray_footprint_mm, 0.5, 1.5)),
    )


def render_session(
    spec: PhantomSpec,
    limb: Limb,
    burn: Burn,
    object_to_world: np.ndarray,
    session: int,
    out_dir: Path,
    session_info: dict | None = None,
) -> tuple[Path, PhantomTruth]:
    started = time.perf_counter()
    texture = skin.apply_burn(limb.skin, burn, spec.healing, stream(spec, Stream.burn_look), spec.burn_look)
    scene = build_scene(
        limb.surface,
        burn,
        object_to_world,
        texture,
        limb.cloth,
        limb.marker_texture,
        limb.marker_ids,
        limb.mesh_spacing_mm,
        stream(spec, Stream.placement, session),
    )
    cameras = sample_cameras(
        scene,
        spec.views,
        spec.width,
        spec.height,
        spec.hfov_deg,
        (spec.distance_min_mm, spec.distance_max_mm),
        stream(spec, Stream.cameras, session),
    )
    for sub in ("images", "masks", "object_masks"):
        (out_dir / sub).mkdir(parents=True, exist_ok=True)
        for stale in (out_dir / sub).glob("view_*.*"):  # an earlier render with more views must not linger
            stale.unlink()
    focal = float(cameras[0].K[0, 0])

    def shoot(i: int) -> None:
        camera = cameras[i]
        view = render_view(scene, camera, spec.supersample, stream(spec, Stream.render, session, i))
        rgb = develop(view.linear, stream(spec, Stream.noise, session, i))
        write_jpeg(
            out_dir / "images" / f"{camera.name}.jpg", rgb, spec.jpeg_quality, focal if spec.exif else None, GENERATOR
        )
        write_mask(out_dir / "masks" / f"{camera.name}.png", view.burn_mask)
        write_mask(out_dir / "object_masks" / f"{camera.name}.png", view.object_mask)

    # Two views at a time: one's numpy shading overlaps the other's (multi-threaded) ray casting.
    with ThreadPoolExecutor(max_workers=RENDER_THREADS) as pool:
        list(pool.map(shoot, range(len(cameras))))
    rendered = time.perf_counter()

    figures = burn_figures(scene)
    surface_check = write_true_surface(out_dir / "true_surface.npz", *true_surface(scene))
    figures.checks["true_surface_mesh"] = surface_check
    figures.checks["area_rel_diff_true_surface_vs_quadrature"] = relative_difference(
        surface_check["area_mm2"], figures.quadrature["area_mm2"]
    )
    focal_mm, focal_35 = exif_focal(spec.width, spec.height, focal)
    info = {
        "spec": msgspec.to_builtins(spec),
        "surface": limb.surface.describe(),
        "burn": burn.describe(),
        "appearance": {**skin.appearance(spec.tone, spec.healing), "burn_look": spec.burn_look.value},
        "lights": scene.lights.describe(),
        "drape": drape.describe(limb.cloth),
        "render": {
            "supersample": spec.supersample,
            "texture_texel_mm": limb.texel_mm,
            "render_mesh_spacing_mm": limb.mesh_spacing_mm,
            "render_mesh_tris": len(scene.body.faces),
            "exif": {"written": spec.exif, "focal_length_mm": round(focal_mm, 3), "focal_length_35mm": focal_35},
        },
    }
    if session_info:
        info["session"] = session_info
    truth = session_truth(scene, figures, cameras, info, GENERATOR)
    path = out_dir / "ground_truth.json"
    path.write_bytes(encode_json(truth))
    log.info(
        "phantom %s: %d views %dx%d rendered in %.1f s, ground truth in %.1f s",
        out_dir,
        len(cameras),
        spec.width,
        spec.height,
        rendered - started,
        time.perf_counter() - rendered,
    )
    return path, truth


def run(spec: PhantomSpec, out_dir: Path) -> Path:
    """Renders one phantom scene into `out_dir` (view files of an earlier render there are replaced);
    returns the ground_truth.json path."""
    spec = validate(spec)
    limb = prepare(spec)
    path, _ = render_session(spec, limb, limb.burn, np.eye(4), 0, Path(out_dir))
    return path


def run_series(spec: PhantomSpec, out_dir: Path) -> Path:
    """Renders the sessions of a longitudinal series (see processing.phantom.series) into subfolders of
    `out_dir`; returns the top-level ground_truth.json path."""
    spec = validate(spec)
    limb = prepare(spec)
    out_dir = Path(out_dir)
    sessions = []
    for index, stage in enumerate(SERIES):
        burn = size_burn(
            limb.surface,
            scaled(limb.burn, limb.burn.r0_mm, spec.depth_mm * stage.depth_ratio),
            spec.area_cm2 * 100.0 * stage.area_ratio,
        )
        motion = session_motion(stream(spec, Stream.motion, index), index)
        session_spec = msgspec.structs.replace(spec, healing=max(spec.healing, stage.healing))
        info = {
            "day": stage.day,
            "target_area_ratio": stage.area_ratio,
            "depth_ratio": stage.depth_ratio,
            "contraction_factor": burn.r0_mm / limb.burn.r0_mm,
        }
        _, truth = render_session(session_spec, limb, burn, motion, index, out_dir / stage.folder, info)
        sessions.append((stage, burn.r0_mm / limb.burn.r0_mm, truth))
    path = out_dir / "ground_truth.json"
    path.write_bytes(encode_json(series_document(spec, GENERATOR, sessions)))
    return path
