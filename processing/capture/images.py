"""Reading phone pictures for analysis: header first, then only as many pixels as needed.

The header gives the size (and refuses decompression bombs) before any pixel is decoded.
JPEGs are then decoded at a reduced scale by libjpeg itself (1/2, 1/4, 1/8), which is
several times cheaper than a full decode followed by a resize.
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from PIL import Image, ImageOps, UnidentifiedImageError
from pillow_heif import register_heif_opener

from schemas.errors import InvalidInput

register_heif_opener()
# The gate enforces its own, documented pixel limit before decoding; Pillow's warning would be noise.
Image.MAX_IMAGE_PIXELS = None
_REDUCED = {1: cv2.IMREAD_GRAYSCALE, 2: cv2.IMREAD_REDUCED_GRAYSCALE_2, 4: cv2.IMREAD_REDUCED_GRAYSCALE_4,
            8: cv2.IMREAD_REDUCED_GRAYSCALE_8}  # fmt: skip


@dataclass(frozen=True)
class ImageHeader:
    format: str
    """Pillow's name: JPEG, PNG, HEIF."""
    width: int
    height: int
    """Stored size; EXIF orientation may swap the two on display."""
    orientation: int
    """EXIF orientation tag (1 = as stored)."""


@dataclass(frozen=True)
class AnalysisImage:
    header: ImageHeader
    gray: np.ndarray
    """Greyscale pixels at roughly the analysis scale."""
    scale: float
    """gray pixels per full-resolution pixel."""


def read_header(data: bytes, max_pixels: int) -> ImageHeader:
    try:
        with Image.open(io.BytesIO(data)) as im:
            header = ImageHeader(im.format or "unknown", im.width, im.height, int(im.getexif().get(0x0112, 1) or 1))
    except (UnidentifiedImageError, OSError, ValueError, SyntaxError) as exc:
        raise InvalidInput(f"not a readable image: {exc}") from exc
    if header.width * header.height > max_pixels:
        raise InvalidInput(
            f"image of {header.width} x {header.height} pixels is larger than any phone photo "
            f"(limit {max_pixels:,} pixels): refused without decoding"
        )
    return header


def load_for_analysis(source: str | Path | bytes, *, long_side: int, max_pixels: int) -> AnalysisImage:
    """Decode a picture in greyscale at about `long_side` pixels on its long side."""
    data = Path(source).read_bytes() if isinstance(source, (str, Path)) else source
    header = read_header(data, max_pixels)
    if header.format == "JPEG":
        gray = _decode_jpeg_reduced(data, max(header.width, header.height), long_side)
    else:
        gray = _decode_with_pillow(data)
    if gray is None or gray.size == 0:
        raise InvalidInput("the image data is truncated or corrupt: it could not be decoded")
    scale = long_side / max(gray.shape)
    if scale < 1.0:
        gray = cv2.resize(
            gray, (round(gray.shape[1] * scale), round(gray.shape[0] * scale)), interpolation=cv2.INTER_AREA
        )
    return AnalysisImage(header=header, gray=gray, scale=max(gray.shape) / max(header.width, header.height))


def _decode_jpeg_reduced(data: bytes, full_long_side: int, long_side: int) -> np.ndarray | None:
    factor = max((f for f in _REDUCED if full_long_side / f >= long_side), default=1)
    buf = np.frombuffer(data, dtype=np.uint8)
    return cv2.imdecode(buf, _REDUCED[factor])


def _decode_with_pillow(data: bytes) -> np.ndarray:
    try:
        with Image.open(io.BytesIO(data)) as im:
            return np.asarray(ImageOps.grayscale(im))
    except (OSError, ValueError, SyntaxError) as exc:
        raise InvalidInput(f"the image data is truncated or corrupt: {exc}") from exc
