"""Skin and burn appearance in the body part's chart.

Skin: a Fitzpatrick-like base colour, low-frequency mottling and redness, fine grain, pores,
freckles and hairs; enough small, sharp, view-consistent detail for SIFT to match across views.
Burn: a red / pink / white / brown blend with blisters and dark speckle, blended over the skin
with alpha = 1 / (1 + exp(-(1 - s) R(theta) / w)), which is 0.5 exactly on the boundary s = 1
(w sets the 10-90 % edge width), plus a faint redness halo outside it.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from processing.phantom.burn import Burn
from processing.phantom.surfaces import Surface
from processing.phantom.textures import (
    ChartTexture,
    draw_dots,
    draw_strands,
    random_strands,
    sigmoid,
    smooth_noise,
    srgb_to_linear,
    texel_centres,
)
from schemas.phantom import BurnLook, SkinTone

TONE_SRGB = {
    SkinTone.I: (0.96, 0.83, 0.75),
    SkinTone.II: (0.91, 0.74, 0.63),
    SkinTone.III: (0.82, 0.62, 0.50),
    SkinTone.IV: (0.68, 0.48, 0.34),
    SkinTone.V: (0.50, 0.33, 0.22),
    SkinTone.VI: (0.33, 0.22, 0.16),
}
FRECKLES_PER_CM2 = {
    SkinTone.I: 2.5,
    SkinTone.II: 2.2,
    SkinTone.III: 2.0,
    SkinTone.IV: 1.6,
    SkinTone.V: 1.3,
    SkinTone.VI: 1.0,
}
BURN_SRGB = {
    "deep_red": (0.66, 0.09, 0.09),
    "red": (0.85, 0.24, 0.23),
    "pink": (0.94, 0.62, 0.60),
    "white": (0.94, 0.91, 0.85),
    "tan": (0.60, 0.40, 0.27),
    "eschar": (0.18, 0.10, 0.07),
    "healed": (0.90, 0.58, 0.56),
    "blister": (0.95, 0.92, 0.78),
}
EDGE_WIDTH_MM = 1.5
"""10-90 % width of the burn's colour edge."""
LOOKS = {
    # white, tan, blisters (relative density), eschar specks (relative density), deep red bias
    BurnLook.mixed: (1.0, 1.0, 1.0, 1.0, 0.0),
    BurnLook.superficial: (0.0, 0.0, 3.0, 0.1, -0.8),
    BurnLook.deep_partial: (2.2, 0.4, 0.4, 0.8, 0.8),
    BurnLook.full_thickness: (2.5, 2.5, 0.0, 4.0, 0.5),
}
HALO = 0.2
HALO_MM = 4.0
SKIN_SPECULAR = 0.035


def skin_texture(surface: Surface, tone: SkinTone, texel_mm: float, rng: np.random.Generator) -> ChartTexture:
    p0, p1, q0, q1 = surface.chart_bounds()
    shape = (int(math.ceil((q1 - q0) / texel_mm)), int(math.ceil((p1 - p0) / texel_mm)))
    area_cm2 = (p1 - p0) * (q1 - q0) / 100.0
    mm = 1.0 / texel_mm

    def noise(sigma_mm: float) -> np.ndarray:
        return smooth_noise(shape, max(sigma_mm * mm, 0.5), rng)

    base = srgb_to_linear(TONE_SRGB[tone])
    # Fine grain (0.25-0.5 mm) is the "orange peel" a sharp photo of skin shows; it carries most of the texture
    # SfM matches and the quality gate's sharpness figure.
    brightness = np.exp(
        0.07 * noise(25.0) + 0.05 * noise(6.0) + 0.06 * noise(1.5) + 0.11 * noise(0.5) + 0.09 * noise(0.25)
    )
    # Redness only ever adds red: a symmetric term would tint the low side olive.
    redness = np.maximum(0.05 * noise(10.0) + 0.025 * noise(2.0) + 0.02, 0.0)
    albedo = np.empty((*shape, 4), np.float32)
    albedo[..., 0] = base[0] * brightness * (1.0 + redness)
    albedo[..., 1] = base[1] * brightness * (1.0 - 0.6 * redness)
    albedo[..., 2] = base[2] * brightness * (1.0 - 0.3 * redness)
    albedo[..., 3] = SKIN_SPECULAR * np.clip(1.0 + 0.3 * noise(0.5), 0.2, None)

    def darken(coverage: np.ndarray, colour: np.ndarray) -> None:
        albedo[..., :3] *= 1.0 - coverage[..., None] * (1.0 - colour)

    n_pores = int(25 * area_cm2)
    darken(
        draw_dots(
            shape,
            rng.uniform([0, 0], [shape[1], shape[0]], (n_pores, 2)),
            rng.uniform(0.08, 0.2, n_pores) * mm,
            rng.uniform(0.25, 0.5, n_pores),
        ),
        np.array([0.55, 0.5, 0.5], np.float32),
    )
    n_specks = int(3 * area_cm2)
    darken(
        draw_dots(
            shape,
            rng.uniform([0, 0], [shape[1], shape[0]], (n_specks, 2)),
            rng.uniform(0.15, 0.35, n_specks) * mm,
            rng.uniform(0.2, 0.45, n_specks),
        ),
        np.array([0.5, 0.42, 0.38], np.float32),
    )
    n_freckles = int(FRECKLES_PER_CM2[tone] * area_cm2)
    darken(
        draw_dots(
            shape,
            rng.uniform([0, 0], [shape[1], shape[0]], (n_freckles, 2)),
            rng.lognormal(math.log(0.4), 0.45, n_freckles) * mm,
            rng.uniform(0.35, 0.8, n_freckles),
        ),
        np.array([0.45, 0.38, 0.34], np.float32),
    )
    n_hairs = int(surface.hair_density_per_cm2 * area_cm2)
    hairs = random_strands(rng, n_hairs, shape, (3.0 * mm, 11.0 * mm), surface.hair_angle_deg, 18.0)
    darken(draw_strands(shape, hairs, rng.uniform(0.35, 0.75, n_hairs)), srgb_to_linear((0.16, 0.11, 0.08)))
    return ChartTexture(image=albedo, origin=(p0, q0), texel_mm=texel_mm)


def burn_alpha(burn: Burn, s: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Burn colour weight: exactly 0.5 on the boundary s = 1."""
    w = EDGE_WIDTH_MM / (2 * math.log(9.0))
    return sigmoid((1.0 - s) * burn.radius(theta) / w)


def apply_burn(
    skin: ChartTexture, burn: Burn, healing: float, rng: np.random.Generator, look: BurnLook = BurnLook.mixed
) -> ChartTexture:
    """A copy of the skin texture with the burn painted in (only texels near the burn are touched)."""
    image = skin.image.copy()
    t = skin.texel_mm
    reach = 1.0 + (HALO_MM * 4 + EDGE_WIDTH_MM * 3) / burn.r0_mm
    r_max = float(burn.radius(np.linspace(0, 2 * math.pi, 720)).max()) * reach
    cp, cq = burn.centre
    c0, c1 = (int(np.clip((v - skin.origin[0]) / t, 0, image.shape[1])) for v in (cp - r_max, cp + r_max))
    r0, r1 = (int(np.clip((v - skin.origin[1]) / t, 0, image.shape[0])) for v in (cq - r_max, cq + r_max))
    p, q = texel_centres(image.shape[:2], skin.origin, t, (r0, r1, c0, c1))
    s, theta = burn.polar(p, q)
    alpha = burn_alpha(burn, s, theta).astype(np.float32)[..., None]
    shape = p.shape
    mm = 1.0 / t

    def noise(sigma_mm: float) -> np.ndarray:
        return smooth_noise(shape, max(sigma_mm * mm, 0.5), rng)[..., None]

    col = {k: srgb_to_linear(v) for k, v in BURN_SRGB.items()}
    n1, n2, n3, n4 = noise(6.0), noise(2.5), noise(1.0), noise(0.3)
    centre_bias = (1.0 - np.minimum(s, 1.0))[..., None]
    fresh = 1.0 - healing
    white_w, tan_w, blister_w, eschar_w, red_bias = LOOKS[look]
    c = col["red"] + (col["deep_red"] - col["red"]) * sigmoid(1.5 * n1 + 2.0 * red_bias)
    c = c + (col["pink"] - c) * 0.8 * sigmoid(2.5 * (n2 - 0.2) - 2.0 * red_bias)
    c = c + (col["white"] - c) * min(white_w, 1.0) * fresh * sigmoid(
        5.0 * (0.7 * n3 + 0.5 * n1 - 1.0 + 0.8 * centre_bias) + 2.0 * (white_w - 1.0)
    )
    c = c + (col["tan"] - c) * min(tan_w, 1.0) * fresh * sigmoid(
        6.0 * (-0.8 * n2 + 0.4 * n3 - 1.3 + 0.5 * centre_bias) + 2.0 * (tan_w - 1.0)
    )
    n_blisters = int(0.6 * blister_w * (r1 - r0) * (c1 - c0) * t * t / 100)
    blisters = draw_dots(
        shape,
        rng.uniform([0, 0], [shape[1], shape[0]], (n_blisters, 2)),
        rng.uniform(0.6, 2.2, n_blisters) * mm,
        rng.uniform(0.4, 0.8, n_blisters),
    )[..., None]
    blisters *= fresh
    c = c + (col["blister"] - c) * blisters
    n_specks = int(4.0 * eschar_w * (r1 - r0) * (c1 - c0) * t * t / 100)
    specks = draw_dots(
        shape,
        rng.uniform([0, 0], [shape[1], shape[0]], (n_specks, 2)),
        rng.uniform(0.12, 0.35, n_specks) * mm,
        rng.uniform(0.5, 0.9, n_specks),
    )[..., None]
    c = c + (col["eschar"] - c) * specks * (0.3 + 0.7 * fresh)
    c = c * (1.0 + 0.06 * n4)
    c = c + (col["healed"] - c) * 0.8 * healing

    patch = image[r0:r1, c0:c1]
    halo = HALO * fresh * np.exp(-np.maximum(s - 1.0, 0.0) * burn.radius(theta) / HALO_MM)[..., None]
    skin_rgb = patch[..., :3] * (1.0 + halo * (np.array([1.12, 0.78, 0.8], np.float32) - 1.0))
    patch[..., :3] = skin_rgb + (c - skin_rgb) * alpha
    burn_spec = 0.10 + 0.25 * blisters[..., 0]
    patch[..., 3] = patch[..., 3] + (burn_spec - patch[..., 3]) * alpha[..., 0]
    return ChartTexture(image=image, origin=skin.origin, texel_mm=t)


def appearance(tone: SkinTone, healing: float) -> dict[str, Any]:
    return {
        "skin_tone": tone.value,
        "skin_srgb": list(TONE_SRGB[tone]),
        "healing": healing,
        "edge_width_mm_10_90": EDGE_WIDTH_MM,
        "halo": HALO,
        "halo_decay_mm": HALO_MM,
        "burn_palette_srgb": {k: list(v) for k, v in BURN_SRGB.items()},
        "blend": "alpha = 1 / (1 + exp(-(1 - s) R(theta) / w)), w = edge_width / (2 ln 9): 0.5 at s = 1",
        "texture": "in the body part's chart: view-consistent; freckles, pores, hairs, mottling",
    }
