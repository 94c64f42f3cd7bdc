"""The region of interest: where the cameras aim (the burn, in practice) and where the marker lies."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from processing.reconstruction.views import View


@dataclass(frozen=True)
class Region:
    """A union of spheres in the output frame."""

    centres: np.ndarray
    radii: np.ndarray

    def contains(self, points: np.ndarray) -> np.ndarray:
        distance = np.linalg.norm(points[:, None, :] - self.centres[None, :, :], axis=2)
        return np.any(distance <= self.radii[None, :], axis=1)

    def depth_range(self, view: View) -> tuple[float, float]:
        depths = view.to_camera(self.centres)[:, 2]
        return float(max(np.min(depths - self.radii), 1e-6)), float(np.max(depths + self.radii))

    def pixel_box(self, view: View) -> tuple[float, float, float, float] | None:
        """Bounding box (x0, y0, x1, y1) of the region's projection, clipped to the picture."""
        boxes = []
        for centre, radius in zip(self.centres, self.radii, strict=True):
            cam = view.to_camera(centre[None, :])[0]
            if cam[2] <= radius:
                continue  # the camera is inside or behind this sphere: skip rather than guess
            focal = view.K[0, 0]
            uv = view.K[:2, :2] @ (cam[:2] / cam[2]) + view.K[:2, 2]
            extent = focal * radius / np.sqrt(cam[2] ** 2 - radius**2) * (1 + np.linalg.norm(cam[:2]) / cam[2])
            boxes.append((uv[0] - extent, uv[1] - extent, uv[0] + extent, uv[1] + extent))
        if not boxes:
            return None
        b = np.array(boxes)
        x0, y0 = max(b[:, 0].min(), 0.0), max(b[:, 1].min(), 0.0)
        x1, y1 = min(b[:, 2].max(), view.width - 1.0), min(b[:, 3].max(), view.height - 1.0)
        if x1 - x0 < 16 or y1 - y0 < 16:
            return None
        return x0, y0, x1, y1


def aim_point(views: list[View]) -> np.ndarray:
    """Least-squares meeting point of the optical axes: what the photographer kept in the centre."""
    a = np.zeros((3, 3))
    b = np.zeros(3)
    for view in views:
        d = view.axis / np.linalg.norm(view.axis)
        projector = np.eye(3) - np.outer(d, d)
        a += projector
        b += projector @ view.centre
    return np.linalg.solve(a, b)


def region_of_interest(views: list[View], radius: float, marker_points: np.ndarray | None) -> Region:
    """Sphere around the aim point, plus one around the marker when there is one."""
    centres = [aim_point(views)]
    radii = [radius]
    if marker_points is not None and len(marker_points):
        centre = marker_points.mean(axis=0)
        centres.append(centre)
        radii.append(float(np.max(np.linalg.norm(marker_points - centre, axis=1))) * 1.3)
    return Region(np.array(centres), np.array(radii))
