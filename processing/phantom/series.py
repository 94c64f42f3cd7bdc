"""A longitudinal series: the same limb photographed on days 0, 7, 14 and 21.

The burn keeps its outline shape and centre in the limb's chart and contracts toward the centre
(R0 re-solved for each day's target area), its crater flattens and its colour heals. Between
sessions the limb is moved on the drape by a known rigid transform (a turn about the vertical and
a shift), the marker strip is laid down again and the photos are new. The top-level
ground_truth.json mirrors the independent generator's series file (../shared/phantoms/p4_series_foot).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import msgspec
import numpy as np

from schemas.phantom import PHANTOM_SERIES_FORMAT, PhantomSpec, PhantomTruth


@dataclass(frozen=True)
class Stage:
    day: int
    area_ratio: float
    """Burn area as a share of day 0's."""
    depth_ratio: float
    """Crater depth as a share of day 0's."""
    healing: float

    @property
    def folder(self) -> str:
        return f"session_day{self.day:02d}"


SERIES = (Stage(0, 1.0, 1.0, 0.0), Stage(7, 0.75, 0.7, 0.25), Stage(14, 0.5, 0.4, 0.5), Stage(21, 0.3, 0.15, 0.75))
MAX_TURN_DEG = 20.0
MAX_SHIFT_MM = 25.0


def session_motion(rng: np.random.Generator, index: int) -> np.ndarray:
    """Object-to-world transform of session `index`: identity on day 0, then a turn about z and a shift in x, y."""
    if index == 0:
        return np.eye(4)
    angle = math.radians(rng.uniform(-MAX_TURN_DEG, MAX_TURN_DEG))
    matrix = np.eye(4)
    matrix[:2, :2] = [[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]]
    matrix[:2, 3] = rng.uniform(-MAX_SHIFT_MM, MAX_SHIFT_MM, 2)
    return matrix


def series_document(
    spec: PhantomSpec, generator: str, sessions: list[tuple[Stage, float, PhantomTruth]]
) -> dict[str, Any]:
    day0 = np.array(sessions[0][2].object_to_world)
    area0 = sessions[0][2].burn_area_cm2
    listing = []
    for stage, contraction, truth in sessions:
        to_world = np.array(truth.object_to_world)
        listing.append(
            {
                "day": stage.day,
                "dir": stage.folder,
                "contraction_factor": contraction,
                "target_area_ratio": stage.area_ratio,
                "depth_ratio": stage.depth_ratio,
                "healing": stage.healing,
                "object_to_world": truth.object_to_world,
                "burn_area_cm2": truth.burn_area_cm2,
                "burn_perimeter_cm": truth.burn_perimeter_cm,
                "max_depth_mm": truth.max_depth_mm,
                "mean_depth_mm": truth.mean_depth_mm,
                "volume_cm3": truth.volume_cm3,
                "reference_area_cm2": truth.reference_area_cm2,
                "area_ratio_vs_day0": truth.burn_area_cm2 / area0,
                "world_day0_to_world_this": (to_world @ np.linalg.inv(day0)).tolist(),
            }
        )
    return {
        "format": PHANTOM_SERIES_FORMAT,
        "generator": generator,
        "units": {"length": "mm", "area": "cm2", "perimeter": "cm", "depth": "mm", "volume": "cm3"},
        "spec": msgspec.to_builtins(spec),
        "object_frame": "the surface chart frame; world_i = object_to_world_i @ x_object",
        "shrink_model": "burn outline contracted toward its chart centre by contraction_factor (R0 solved for the "
        "target area ratio); crater depth scaled by depth_ratio; healing tints the burn toward pink",
        "motion_model": f"day 0 identity; later sessions turn the limb about the vertical by up to {MAX_TURN_DEG:g} "
        f"degrees and shift it by up to {MAX_SHIFT_MM:g} mm on the drape; the drape and marker are "
        "laid out again each session",
        "sessions": listing,
    }
