"""From linear radiance to a phone-like JPEG: exposure, highlight roll-off, sensor noise, sRGB, EXIF.

EXIF carries FocalLength (mm, for a 1/1.7-inch-class sensor) and the 35 mm-equivalent focal
length by the format's diagonal (an integer, as phones write it), so SfM tools can start from
the focal length the way they do with phone photos.
"""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
from PIL import Image, TiffImagePlugin

EXPOSURE = 0.9
KNEE = 0.8
FULL_WELL = 2500.0
"""Photo-electrons at full scale: shot noise sigma = sqrt(x / FULL_WELL)."""
READ_NOISE = 0.002
SENSOR_WIDTH_MM = 7.6
FULL_FRAME_DIAGONAL_MM = 43.27
MAKE, MODEL = "burnedge", "phantom camera"


def develop(linear: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """8-bit sRGB (H, W, 3, RGB order) from linear radiance."""
    x = linear * EXPOSURE
    x = np.where(x < KNEE, x, KNEE + (1.0 - KNEE) * (1.0 - np.exp(-(x - KNEE) / (1.0 - KNEE))))
    sigma = np.sqrt(np.maximum(x, 0.0) / FULL_WELL + READ_NOISE**2)
    x = np.clip(x + sigma * rng.standard_normal(x.shape).astype(np.float32), 0.0, 1.0)
    srgb = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    return np.round(srgb * 255.0).astype(np.uint8)


def exif_focal(width: int, height: int, focal_px: float) -> tuple[float, int]:
    """FocalLength in mm and FocalLengthIn35mmFilm for a pinhole of `focal_px` pixels."""
    return focal_px * SENSOR_WIDTH_MM / width, int(round(focal_px * FULL_FRAME_DIAGONAL_MM / math.hypot(width, height)))


def write_jpeg(path: Path, rgb: np.ndarray, quality: int, focal_px: float | None, software: str) -> None:
    image = Image.fromarray(rgb, "RGB")
    if focal_px is None:
        image.save(path, format="JPEG", quality=quality)
        return
    exif = Image.Exif()
    focal_mm, focal_35 = exif_focal(rgb.shape[1], rgb.shape[0], focal_px)
    exif[0x010F] = MAKE
    exif[0x0110] = MODEL
    exif[0x0131] = software
    sub = exif.get_ifd(0x8769)
    sub[0x920A] = TiffImagePlugin.IFDRational(round(focal_mm * 1000), 1000)  # FocalLength
    sub[0xA405] = focal_35  # FocalLengthIn35mmFilm
    image.save(path, format="JPEG", quality=quality, exif=exif.tobytes())


def write_mask(path: Path, mask: np.ndarray) -> None:
    cv2.imwrite(str(path), np.where(mask, 255, 0).astype(np.uint8))
