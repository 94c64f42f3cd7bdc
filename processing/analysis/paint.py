"""How burn_surface.glb paints the burn over the skin's own colours (processing/analysis/surface_map.py), kept
apart from the analysis so a reader of the glTF alone (the DICOM surface mesh, processing/dicom/mesh.py) applies
the same rule without the analysis's dependencies.

A vertex's colour is skin * (1 - alpha) + PAINT * alpha, alpha rising from 0 at q = 0.3 to MAX_ALPHA at q = 0.7.
"""

from __future__ import annotations

import numpy as np

PAINT = np.array([1.0, 0.16, 0.78])
"""Magenta: distinct from red burns and from every skin tone."""
FROM_Q, SPAN_Q, MAX_ALPHA = 0.3, 0.4, 0.8


def alpha(q: np.ndarray) -> np.ndarray:
    """The paint's share of a vertex's colour for its fused burn probability (NaN: not looked at, unpainted)."""
    return np.clip((np.nan_to_num(q) - FROM_Q) / SPAN_Q, 0, 1) * MAX_ALPHA


def alpha_at(level: float) -> float:
    """The paint's share at probability `level` (0.4 at the burn's 0.5 boundary)."""
    return float(alpha(np.array([level]))[0])
