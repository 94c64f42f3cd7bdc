"""Phone cameras around the burn: one set of pinhole intrinsics, views on a partial hemisphere.

Azimuths, elevations (40-80 degrees) and distances are stratified so the set is spread out,
then jittered; each camera aims near the burn, pulled a quarter of the way toward the marker
strip, with a little roll. A view is kept only if the whole burn boundary is in frame and
unobstructed and the burn is not seen too obliquely; the marker must be fully in view too,
unless no candidate for that slot manages it (so it is visible in most views, not all).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from processing.phantom.scene import Scene
from schemas.errors import InvalidInput

ELEVATION_DEG = (40.0, 80.0)
MAX_BURN_OBLIQUITY_DEG = 65.0
MARKER_PULL = 0.25
TRIES_WITH_MARKER = 40
TRIES = 200


@dataclass(frozen=True)
class Camera:
    name: str
    width: int
    height: int
    K: np.ndarray
    R: np.ndarray
    """World to camera rotation: x_cam = R x_world + t."""
    t: np.ndarray

    @property
    def centre(self) -> np.ndarray:
        return -self.R.T @ self.t

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pixel coordinates (OpenCV convention) and depths of world points."""
        cam = points @ self.R.T + self.t
        return (cam[:, :2] / cam[:, 2:3]) @ self.K[:2, :2].T + self.K[:2, 2], cam[:, 2]

    def in_frame(self, points: np.ndarray, margin: float) -> bool:
        px, depth = self.project(points)
        m = margin * self.width
        return bool(
            (depth > 0).all()
            and (px[:, 0] >= m).all()
            and (px[:, 0] <= self.width - 1 - m).all()
            and (px[:, 1] >= m).all()
            and (px[:, 1] <= self.height - 1 - m).all()
        )


def intrinsics(width: int, height: int, hfov_deg: float) -> np.ndarray:
    f = (width / 2) / math.tan(math.radians(hfov_deg) / 2)
    return np.array([[f, 0.0, width / 2], [0.0, f, height / 2], [0.0, 0.0, 1.0]])


def look_at(centre: np.ndarray, target: np.ndarray, roll_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """R, t of a camera at `centre` looking at `target`, the image's top toward world +z, then rolled."""
    forward = (target - centre) / np.linalg.norm(target - centre)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    c, s = math.cos(math.radians(roll_deg)), math.sin(math.radians(roll_deg))
    right, down = c * right + s * down, -s * right + c * down
    rotation = np.stack([right, down, forward])
    return rotation, -rotation @ centre


def _stratified(rng: np.random.Generator, n: int, lo: float, hi: float) -> np.ndarray:
    return lo + (hi - lo) * (rng.permutation(n) + rng.uniform(0.15, 0.85, n)) / n


def sample_cameras(
    scene: Scene,
    views: int,
    width: int,
    height: int,
    hfov_deg: float,
    distance_mm: tuple[float, float],
    rng: np.random.Generator,
) -> list[Camera]:
    K = intrinsics(width, height, hfov_deg)
    burn_centre, burn_normal = scene.burn_centre_world()
    boundary = scene.boundary_world(120)
    corners = np.concatenate(list(scene.strip.corners().values()))
    pull = MARKER_PULL * (corners.mean(axis=0) - burn_centre)
    azimuth0 = rng.uniform(0, 2 * math.pi)
    elevations = _stratified(rng, views, *ELEVATION_DEG)
    distances = _stratified(rng, views, *distance_mm)
    cameras = []
    for i in range(views):
        chosen = None
        for attempt in range(TRIES):
            spread = 0.35 if attempt < 10 else 0.5 + attempt / TRIES
            azimuth = azimuth0 + 2 * math.pi * (i + rng.uniform(-spread, spread)) / views
            elevation = math.radians(np.clip(elevations[i] + rng.normal(0, 3 + 0.1 * attempt), *ELEVATION_DEG))
            distance = float(np.clip(distances[i] + rng.normal(0, 10), *distance_mm))
            direction = np.array(
                [math.cos(elevation) * math.cos(azimuth), math.cos(elevation) * math.sin(azimuth), math.sin(elevation)]
            )
            if math.degrees(math.acos(np.clip(direction @ burn_normal, -1, 1))) > MAX_BURN_OBLIQUITY_DEG:
                continue
            centre = burn_centre + distance * direction
            target = burn_centre + pull + rng.normal(0, 8.0, 3)
            R, t = look_at(centre, target, float(rng.normal(0, 8.0)))
            camera = Camera(name=f"view_{i:03d}", width=width, height=height, K=K, R=R, t=t)
            if not camera.in_frame(boundary, 0.03) or not scene.visible(centre, boundary).all():
                continue
            if camera.in_frame(corners, 0.02) and scene.visible(centre, corners).all():
                chosen = camera
                break
            if chosen is None:  # the first that frames the burn, in case none frames the marker as well
                chosen = camera
            if attempt >= TRIES_WITH_MARKER:
                break
        if chosen is None:
            raise InvalidInput(
                f"could not place camera {i} so that it sees the whole burn: with a "
                f"{math.degrees(2 * math.atan(width / 2 / K[0, 0])):.0f} degree field of view, "
                "use larger distances or a smaller burn"
            )
        cameras.append(chosen)
    return cameras
