"""A session's ground truth: the burn's figures and their cross-checks, the true surface mesh, and
ground_truth.json in the layout the independent generator (../shared/phantoms) uses.
"""

from __future__ import annotations

import math
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import msgspec
import numpy as np

from processing.phantom import truth
from processing.phantom.burn import displaced_point
from processing.phantom.cameras import Camera
from processing.phantom.meshing import adaptive_ring_mesh, compact, edge_lengths, triangle_areas
from processing.phantom.scene import Scene, transform
from schemas.phantom import PHANTOM_FORMAT, PhantomCamera, PhantomMarker, PhantomTruth

TRUE_SURFACE_EDGE_MM = 0.25
TRUE_SURFACE_REACH = 2.5
"""The true surface covers s <= 2.5: about 2.5 burn radii around the centre."""
TRUE_SURFACE_FACING = 0.5
"""...and to skin whose normal is within 60 degrees of the burn's (not the steep flanks down to the drape)."""
BOUNDARY_POINTS = 360

UNITS = {
    "length": "mm",
    "area": "cm2",
    "perimeter": "cm",
    "depth": "mm",
    "volume": "cm3",
    "world": "mm, z up; the drape is z = 0 around the body part and marker (folds further out)",
}
CAMERA_CONVENTIONS = {
    "model": "pinhole, no distortion",
    "extrinsics": "x_cam = R @ x_world + t (world->camera), camera x right, y down, z forward",
    "pixels": "OpenCV: centre of the top-left pixel is (0,0); add 0.5 to cx, cy for COLMAP's convention",
}
DEFINITIONS = {
    "burn_area_cm2": "area of the displaced (cratered) skin surface inside the burn boundary",
    "reference_area_cm2": "area of the undisplaced surface inside the boundary",
    "burn_perimeter_cm": "length of the burn boundary on the surface (the crater depth is 0 there)",
    "max_depth_mm": "largest inward normal displacement (at the burn centre)",
    "mean_depth_mm": "area-weighted mean inward displacement over the undisplaced burn surface",
    "volume_cm3": "volume enclosed between the undisplaced and displaced surfaces",
    "figures": "the headline figures are the quadrature values; checks gives both methods and their relative "
    "differences",
    "boundary": "s = r / R(theta) = 1 in the burn's polar chart; the colour blend alpha is 0.5 exactly there",
    "masks": "masks/view_NNN.png: 255 where more than half the pixel's area is burn (s <= 1 on the body part); "
    "object_masks/: the same for any skin of the body part",
    "burn_centre_world_mm": "burn centre on the undisplaced surface; the crater bottom is burn_centre - "
    "max_depth_mm * burn_normal_world",
    "burn_normal_world": "outward unit surface normal at the burn centre (undisplaced surface)",
    "burn_boundary_world_mm": f"{BOUNDARY_POINTS} boundary points, evenly spaced in the chart angle theta",
    "true_surface": f"true_surface.npz: vertices (float64 N x 3, world mm) and faces (int32 M x 3, counter-"
    f"clockwise seen from outside) of the displaced body-part surface for s <= {TRUE_SURFACE_REACH} "
    f"(clipped to smooth skin facing within 60 degrees of the burn normal), edges <= {TRUE_SURFACE_EDGE_MM} mm; burn_s (float64 N) is each vertex's "
    "s, with a ring of vertices exactly at s = 1: the burn is the faces whose vertices all have "
    "burn_s <= 1",
    "object_to_world": "4x4 rigid transform from the body part's own frame (the chart's) to the world",
}


@dataclass(frozen=True)
class BurnFigures:
    quadrature: dict[str, Any]
    checks: dict[str, Any]


def burn_figures(scene: Scene) -> BurnFigures:
    by_quadrature = truth.quadrature(scene.surface, scene.burn)
    return BurnFigures(
        quadrature=by_quadrature, checks=truth.cross_checks(by_quadrature, truth.fine_mesh(scene.surface, scene.burn))
    )


def true_surface(scene: Scene) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World vertices, faces and per-vertex burn s of the displaced surface around the burn."""
    surface, burn = scene.surface, scene.burn
    centre_normal = surface.normal(*(np.array([c]) for c in burn.centre))[0]

    def kept(s: np.ndarray, t: np.ndarray) -> np.ndarray:
        p, q = burn.chart_point(s, t)
        smooth = surface.smooth_skin(p, q)
        facing = np.zeros_like(smooth)
        facing[smooth] = surface.normal(p[smooth], q[smooth]) @ centre_normal >= TRUE_SURFACE_FACING
        return facing

    edge = TRUE_SURFACE_EDGE_MM
    for _ in range(4):
        mesh = adaptive_ring_mesh(
            lambda s, t: displaced_point(surface, burn, s, t), TRUE_SURFACE_REACH, edge, keep=kept
        )
        faces, old = compact(kept(mesh.s, mesh.theta), mesh.faces)
        vertices = displaced_point(surface, burn, mesh.s[old], mesh.theta[old])
        longest = float(edge_lengths(vertices, faces).max())
        if longest <= TRUE_SURFACE_EDGE_MM:
            break
        edge *= 0.97 * TRUE_SURFACE_EDGE_MM / longest
    return transform(scene.object_to_world, vertices), faces.astype(np.int32), mesh.s[old]


def write_true_surface(path: Path, vertices: np.ndarray, faces: np.ndarray, burn_s: np.ndarray) -> dict[str, Any]:
    """Writes the npz; returns its burn area (faces with s <= 1) and sizes, for the checks."""
    arrays = {"vertices": vertices.astype(np.float64), "faces": faces, "burn_s": burn_s.astype(np.float64)}
    # np.savez_compressed's deflate level costs seconds here for little gain; level 1 is a plain npz all the same.
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=1) as archive:
        for name, array in arrays.items():
            with archive.open(f"{name}.npy", "w", force_zip64=True) as member:
                np.lib.format.write_array(member, array, allow_pickle=False)
    inside = (burn_s[faces] <= 1.0).all(axis=1)
    return {
        "area_mm2": float(triangle_areas(vertices, faces[inside]).sum()),
        "vertices": len(vertices),
        "triangles": len(faces),
        "max_edge_mm": float(edge_lengths(vertices, faces).max()),
    }


def _numpy_scalar(obj: Any) -> Any:
    if isinstance(obj, np.generic | np.ndarray):
        return obj.tolist()
    raise TypeError(f"cannot write {type(obj).__name__} to JSON")


_ENCODER = msgspec.json.Encoder(enc_hook=_numpy_scalar)


def encode_json(document: Any) -> bytes:
    """Indented JSON; numpy numbers and arrays become plain ones."""
    return msgspec.json.format(_ENCODER.encode(document), indent=2) + b"\n"


def camera_record(camera: Camera) -> PhantomCamera:
    hfov = math.degrees(2 * math.atan(camera.width / 2 / camera.K[0, 0]))
    return PhantomCamera(
        name=camera.name,
        width=camera.width,
        height=camera.height,
        K=camera.K.tolist(),
        R=camera.R.tolist(),
        t=camera.t.tolist(),
        hfov_deg=hfov,
    )


def session_truth(
    scene: Scene, figures: BurnFigures, cameras: list[Camera], scene_info: dict[str, Any], generator: str
) -> PhantomTruth:
    q = figures.quadrature
    centre, normal = scene.burn_centre_world()
    strip = scene.strip.describe()
    return PhantomTruth(
        format=PHANTOM_FORMAT,
        generator=generator,
        units=UNITS,
        scene=scene_info,
        burn_area_cm2=q["area_mm2"] / 100.0,
        reference_area_cm2=q["ref_area_mm2"] / 100.0,
        burn_perimeter_cm=q["perimeter_mm"] / 10.0,
        max_depth_mm=q["max_depth_mm"],
        mean_depth_mm=q["mean_depth_mm"],
        volume_cm3=q["volume_mm3"] / 1000.0,
        definitions=DEFINITIONS,
        checks=figures.checks,
        object_to_world=scene.object_to_world.tolist(),
        burn_centre_world_mm=centre.tolist(),
        burn_normal_world=normal.tolist(),
        burn_boundary_world_mm=scene.boundary_world(BOUNDARY_POINTS).tolist(),
        marker=PhantomMarker(**strip),
        camera_conventions=CAMERA_CONVENTIONS,
        cameras=[camera_record(c) for c in cameras],
    )
