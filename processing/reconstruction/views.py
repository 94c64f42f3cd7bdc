"""Placed pictures as plain numpy cameras (OpenCV pixel convention), read from a COLMAP model."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
import pycolmap

from schemas.errors import InvalidInput

# COLMAP camera models -> (index of fx, fy, cx, cy, then OpenCV k1, k2, p1, p2); -1 = absent (0 or fx).
_MODELS: dict[str, tuple[int, int, int, int, int, int, int, int]] = {
    "SIMPLE_PINHOLE": (0, 0, 1, 2, -1, -1, -1, -1),
    "PINHOLE": (0, 1, 2, 3, -1, -1, -1, -1),
    "SIMPLE_RADIAL": (0, 0, 1, 2, 3, -1, -1, -1),
    "RADIAL": (0, 0, 1, 2, 3, 4, -1, -1),
    "OPENCV": (0, 1, 2, 3, 4, 5, 6, 7),
}


@dataclass
class View:
    """One placed picture. x_cam = R @ x_world + t; pixel centres at integers (OpenCV)."""

    name: str
    image_id: int
    width: int
    height: int
    K: np.ndarray
    dist: np.ndarray
    R: np.ndarray
    t: np.ndarray
    _maps: dict = field(default_factory=dict, repr=False)

    @property
    def centre(self) -> np.ndarray:
        return -self.R.T @ self.t

    @property
    def axis(self) -> np.ndarray:
        """Viewing direction (optical axis) in world coordinates."""
        return self.R[2]

    def to_camera(self, points: np.ndarray) -> np.ndarray:
        return points @ self.R.T + self.t

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Undistorted pixel coordinates (N, 2) and depths (N,) of world points."""
        cam = self.to_camera(points)
        z = cam[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            uv = (cam[:, :2] / z[:, None]) @ self.K[:2, :2].T + self.K[:2, 2]
        return uv, z

    def projection_matrix(self) -> np.ndarray:
        return self.K @ np.hstack([self.R, self.t[:, None]])

    def undistort_points(self, pixels: np.ndarray) -> np.ndarray:
        """Detected (distorted) pixel positions -> positions in the undistorted pinhole image."""
        if not np.any(self.dist):
            return np.asarray(pixels, dtype=np.float64)
        pts = cv2.undistortPoints(np.asarray(pixels, np.float64).reshape(-1, 1, 2), self.K, self.dist, P=self.K)
        return pts.reshape(-1, 2)

    def undistort_image(self, image: np.ndarray, outside: float | None = None) -> np.ndarray:
        """The picture as a distortion-free pinhole camera with the same K. Pixels that fall outside the
        sensor repeat its edge, or take the value `outside` when one is given (e.g. NaN: unknown)."""
        if not np.any(self.dist):
            return image
        if "full" not in self._maps:
            self._maps["full"] = cv2.initUndistortRectifyMap(
                self.K, self.dist, None, self.K, (self.width, self.height), cv2.CV_32FC1
            )
        mx, my = self._maps["full"]
        if outside is None:
            return cv2.remap(image, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        return cv2.remap(image, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=outside)

    def distort_points(self, pixels: np.ndarray) -> np.ndarray:
        """Undistorted (pinhole) pixel positions -> where they lie in the picture as taken."""
        if not np.any(self.dist):
            return np.asarray(pixels, dtype=np.float64)
        rays = cv2.undistortPoints(np.asarray(pixels, np.float64).reshape(-1, 1, 2), self.K, None)
        rays = np.concatenate([rays.reshape(-1, 2), np.ones((len(rays), 1))], axis=1)
        pts, _ = cv2.projectPoints(rays, np.zeros(3), np.zeros(3), self.K, self.dist)
        return pts.reshape(-1, 2)


def camera_intrinsics(camera: pycolmap.Camera) -> tuple[np.ndarray, np.ndarray]:
    """OpenCV K (pixel centres at integers) and distortion (k1, k2, p1, p2) of a COLMAP camera."""
    layout = _MODELS.get(camera.model_name)
    if layout is None:
        raise InvalidInput(f"camera model {camera.model_name} is not supported; use one of {', '.join(_MODELS)}")
    p = np.asarray(camera.params, dtype=np.float64)
    fx, fy, cx, cy = (p[i] for i in layout[:4])
    # COLMAP puts the centre of the top-left pixel at (0.5, 0.5); OpenCV at (0, 0).
    K = np.array([[fx, 0.0, cx - 0.5], [0.0, fy, cy - 0.5], [0.0, 0.0, 1.0]])
    dist = np.array([p[i] if i >= 0 else 0.0 for i in layout[4:]])
    return K, dist


def load_views(model: pycolmap.Reconstruction) -> list[View]:
    """Every registered picture of a model, sorted by name."""
    views = []
    for image_id in model.reg_image_ids():
        image = model.images[image_id]
        K, dist = camera_intrinsics(model.cameras[image.camera_id])
        pose = image.cam_from_world().matrix()
        camera = model.cameras[image.camera_id]
        views.append(
            View(image.name, image_id, camera.width, camera.height, K, dist, pose[:, :3].copy(), pose[:, 3].copy())
        )
    return sorted(views, key=lambda v: v.name)


def read_model(path: Path) -> pycolmap.Reconstruction:
    if not (path / "images.bin").exists() and not (path / "images.txt").exists():
        raise InvalidInput(f"{path} holds no COLMAP model (images.bin)")
    return pycolmap.Reconstruction(str(path))


def read_gray(path: Path) -> np.ndarray:
    """Pixels as stored, like COLMAP reads them (EXIF orientation is not applied, so poses match)."""
    image = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE | cv2.IMREAD_IGNORE_ORIENTATION)
    if image is None:
        raise InvalidInput(f"{path.name} could not be decoded as an image")
    return image


def read_colour(path: Path) -> np.ndarray:
    image = cv2.imread(str(path), cv2.IMREAD_COLOR | cv2.IMREAD_IGNORE_ORIENTATION)
    if image is None:
        raise InvalidInput(f"{path.name} could not be decoded as an image")
    return image


def read_rgb(path: Path) -> np.ndarray:
    """The picture as stored (EXIF orientation not applied), RGB uint8."""
    return cv2.cvtColor(read_colour(path), cv2.COLOR_BGR2RGB)
