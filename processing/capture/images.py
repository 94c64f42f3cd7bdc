"""Reading phone pictures for analysis: header first, then only as many pixels as needed.

The header gives the size (and refuses decompression bombs) before any pixel is decoded:
only the file's header and its EXIF block are parsed, never Pillow's `getexif()`, which
decodes a whole PNG to look for an EXIF chunk after the pixel data. JPEGs are then decoded
at a reduced scale by libjpeg itself (Pillow's draft mode: 1/2, 1/4, 1/8), several times
cheaper than a full decode followed by a resize. Other formats are decoded straight to one
byte of grey per pixel (PNG by libpng through OpenCV), so decoding memory stays near
width x height bytes, whatever the colour depth. Decoders raise on truncated data, so the
same decode proves the file is whole.
"""

from __future__ import annotations

import io
import struct
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from PIL import Image, ImageOps, UnidentifiedImageError
from pillow_heif import register_heif_opener

from schemas.errors import InvalidInput, plain

register_heif_opener()
# The gate enforces its own, documented pixel limit before decoding; Pillow's warning would be noise.
Image.MAX_IMAGE_PIXELS = None


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
    """Format, size and orientation from the header alone; over-limit sizes are refused here."""
    try:
        with Image.open(io.BytesIO(data)) as im:
            fmt, width, height = im.format or "unknown", im.width, im.height
            if width * height > max_pixels:
                raise InvalidInput(
                    f"image of {width} x {height} pixels is larger than this gateway accepts "
                    f"(limit {max_pixels:,} pixels; a 48 MP phone photo is about 48,000,000): refused without "
                    "decoding. Take the photo in the camera's default mode, not a high-resolution or panorama one"
                )
            header = ImageHeader(fmt, width, height, _orientation(im.info.get("exif")))
    except (UnidentifiedImageError, OSError, ValueError, SyntaxError) as exc:
        raise InvalidInput(f"not a photo this gateway can read (JPEG, PNG or HEIC): {plain(exc)}") from exc
    return header


def _orientation(raw_exif: bytes | None) -> int:
    """The EXIF orientation tag from the raw EXIF block the header parse found (1 when there is none)."""
    if not raw_exif:
        return 1
    exif = Image.Exif()
    try:
        exif.load(raw_exif)
        value = int(exif.get(0x0112, 1) or 1)
    except (OSError, ValueError, TypeError, SyntaxError, struct.error):
        return 1  # a damaged EXIF block only loses the orientation hint; the pixels are checked separately
    return value if 1 <= value <= 8 else 1


def load_for_analysis(source: str | Path | bytes, *, long_side: int, max_pixels: int) -> AnalysisImage:
    """Decode a picture in greyscale at about `long_side` pixels on its long side."""
    data = Path(source).read_bytes() if isinstance(source, (str, Path)) else source
    header = read_header(data, max_pixels)
    return analysis_copy(_decode_gray(data, header, long_side), header, long_side)


def analysis_copy(gray: np.ndarray, header: ImageHeader, long_side: int) -> AnalysisImage:
    """Greyscale pixels (full or partly reduced) brought down to about `long_side`."""
    scale = long_side / max(gray.shape)
    if scale < 1.0:
        size = (round(gray.shape[1] * scale), round(gray.shape[0] * scale))
        gray = cv2.resize(gray, size, interpolation=cv2.INTER_AREA)
    return AnalysisImage(header=header, gray=gray, scale=max(gray.shape) / max(header.width, header.height))


def _decode_gray(data: bytes, header: ImageHeader, long_side: int) -> np.ndarray:
    if header.format == "PNG":
        return _decode_png_gray(data)
    try:
        with Image.open(io.BytesIO(data)) as im:
            if header.format == "JPEG":
                factor = long_side / max(header.width, header.height)
                im.draft("L", (max(1, int(header.width * factor)), max(1, int(header.height * factor))))
            gray = np.asarray(ImageOps.grayscale(im))
    except (OSError, ValueError, SyntaxError) as exc:
        raise InvalidInput(f"the image data is truncated or corrupt: {plain(exc)}") from exc
    if gray.size == 0:
        raise InvalidInput("the image has no pixels")
    return gray


def _decode_png_gray(data: bytes) -> np.ndarray:
    """libpng converts to 8-bit grey row by row: one byte per pixel, where Pillow would hold RGBA then grey."""
    buffer = np.frombuffer(data, dtype=np.uint8)
    gray = cv2.imdecode(buffer, cv2.IMREAD_GRAYSCALE | cv2.IMREAD_IGNORE_ORIENTATION)
    if gray is None or gray.size == 0:
        raise InvalidInput("the PNG's pixel data is truncated or corrupt")
    return gray
