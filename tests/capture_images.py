"""Pictures made by the tests: a textured scene with a printed ArUco marker, and its defects."""

from __future__ import annotations

import io
import struct
import zlib

import cv2
import numpy as np
from PIL import Image
from pillow_heif import register_heif_opener

register_heif_opener()


def scene(
    width: int = 1600, height: int = 1200, *, marker_px: int = 120, marker_id: int = 7, seed: int = 1
) -> np.ndarray:
    """A skin-coloured, finely textured surface with a marker on a white margin (BGR)."""
    rng = np.random.default_rng(seed)
    # Skin photographed at phone resolution: pores and hair give detail at the pixel scale,
    # on top of broader mottling.
    fine = cv2.GaussianBlur(rng.normal(0, 1, (height, width)).astype(np.float32), (0, 0), 0.8)
    coarse = cv2.resize(
        rng.normal(0, 1, (height // 16, width // 16)).astype(np.float32), (width, height), interpolation=cv2.INTER_CUBIC
    )
    texture = 0.7 * fine / fine.std() + 0.5 * coarse / coarse.std()
    texture = np.clip(0.5 + 0.15 * texture, 0, 1)
    base = np.array([110, 150, 200], np.float32)  # BGR skin tone
    img = base[None, None, :] * (0.6 + 0.6 * texture[..., None])
    img = np.clip(img, 0, 255).astype(np.uint8)
    if marker_px:
        dictionary = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50)
        marker = cv2.aruco.generateImageMarker(dictionary, marker_id, marker_px)
        margin = marker_px // 4
        y, x = height // 8, width // 8
        img[y - margin : y + marker_px + margin, x - margin : x + marker_px + margin] = 255
        img[y : y + marker_px, x : x + marker_px] = marker[..., None]
    return img


def jpeg(img: np.ndarray, quality: int = 90) -> bytes:
    return cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, quality])[1].tobytes()


def heic(img: np.ndarray) -> bytes:
    out = io.BytesIO()
    Image.fromarray(cv2.cvtColor(img, cv2.COLOR_BGR2RGB)).save(out, format="HEIF", quality=85)
    return out.getvalue()


def exposed(img: np.ndarray, gain: float) -> np.ndarray:
    linear = (img.astype(np.float32) / 255.0) ** 2.2 * gain
    return (np.clip(linear, 0, 1) ** (1 / 2.2) * 255).round().astype(np.uint8)


def _png_chunk(kind: bytes, body: bytes) -> bytes:
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))


def _png(ihdr: bytes, *chunks: tuple[bytes, bytes]) -> bytes:
    body = b"".join(_png_chunk(kind, data) for kind, data in chunks)
    return b"\x89PNG\r\n\x1a\n" + _png_chunk(b"IHDR", ihdr) + body + _png_chunk(b"IEND", b"")


def png_bomb(side: int = 40_000) -> bytes:
    """A valid greyscale PNG of side x side black pixels: a few MB that would decode to 1.6 GB."""
    row = b"\x00" * (side + 1)
    comp = zlib.compressobj(1)
    data = b"".join(comp.compress(row) for _ in range(side)) + comp.flush()

    ihdr = struct.pack(">IIBBBBB", side, side, 8, 0, 0, 0, 0)
    return _png(ihdr, (b"IDAT", data))


def png_header_bomb(side: int = 100_000) -> bytes:
    """A few hundred bytes whose header declares side x side RGB pixels, with an EXIF chunk after the pixel data
    (where Pillow's getexif() would decode the whole image to find it)."""

    exif = Image.Exif()
    exif[0x0112] = 6
    ihdr = struct.pack(">IIBBBBB", side, side, 8, 2, 0, 0, 0)
    idat = zlib.compress(b"\x00" * 256, 9)
    return _png(ihdr, (b"IDAT", idat), (b"eXIf", exif.tobytes()))


def rgb_png(width: int, height: int) -> bytes:
    """A valid, highly compressible RGB PNG: a few hundred kB that decode to width x height x 3 bytes."""
    row = b"\x00" + b"\x80\x60\x40" * width
    comp = zlib.compressobj(1)
    data = b"".join(comp.compress(row) for _ in range(height)) + comp.flush()

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return _png(ihdr, (b"IDAT", data))


def video(
    path,
    codec: str = "libx264",
    seconds: float = 2.0,
    size: tuple[int, int] = (960, 720),
    fps: int = 30,
    *,
    still: bool = False,
    blur_except_every: int = 0,
    pix_fmt: str = "yuv420p",
    rotation: int = 0,
    crf: int | None = None,
) -> bytes:
    """A short phone-like clip (camera panning over the textured scene, I/P frames only), via PyAV.

    still: the camera does not move (every frame shows pan_scene(size)[:, :width]).
    blur_except_every=n: every frame but each n-th is blurred. pix_fmt: "yuv420p10le" with libx265
    gives 10-bit video like an iPhone's HDR HEVC. rotation: the display rotation tag, degrees
    counter-clockwise (an iPhone held upright writes -90). crf: the encoder's quality (lower is
    better; x264 defaults to 23, x265 to 28, which softens frames below the gate's threshold).
    """
    import av

    w, h = size
    big = pan_scene(size)
    with av.open(str(path), "w") as out:
        stream = out.add_stream(codec, rate=fps)
        stream.width, stream.height, stream.pix_fmt = w, h, pix_fmt
        stream.options = {"x265-params": "log-level=none:bframes=0"} if codec == "libx265" else {"bf": "0"}
        if crf is not None:
            stream.options = {**stream.options, "crf": str(crf)}
        if rotation:
            stream.set_display_rotation(rotation)
        frames = int(seconds * fps)
        for i in range(frames):
            x = 0 if still else int(i / max(1, frames - 1) * w)
            view = big[:, x : x + w]
            if blur_except_every and i % blur_except_every:
                view = cv2.GaussianBlur(view, (0, 0), 3)
            frame = av.VideoFrame.from_ndarray(cv2.cvtColor(view, cv2.COLOR_BGR2RGB), format="rgb24")
            for packet in stream.encode(frame):
                out.mux(packet)
        for packet in stream.encode():
            out.mux(packet)
    with open(path, "rb") as f:
        return f.read()


def pad_mp4(data: bytes, extra_bytes: int, seed: int = 0) -> bytes:
    """The same MP4 made larger by an ISO 'free' box of random bytes, which players skip."""
    payload = np.random.default_rng(seed).integers(0, 256, extra_bytes, dtype=np.uint8).tobytes()
    return data + struct.pack(">I", len(payload) + 8) + b"free" + payload


def jpeg_with_exif(img: np.ndarray) -> bytes:
    exif = Image.Exif()
    exif[0x010F] = "TestPhone Inc."  # Make
    exif[0x0110] = "Model 7"  # Model
    exif[0x0112] = 6  # Orientation: rotated 90 degrees
    sub = exif.get_ifd(0x8769)
    sub[0x9003] = "2026:11:22 10:15:00"  # DateTimeOriginal
    sub[0x920A] = 4.25  # FocalLength
    sub[0xA405] = 26  # FocalLengthIn35mmFilm
    out = io.BytesIO()
    Image.fromarray(cv2.cvtColor(img, cv2.COLOR_BGR2RGB)).save(out, format="JPEG", quality=90, exif=exif)
    return out.getvalue()


def pan_scene(size: tuple[int, int]) -> np.ndarray:
    """The scene a video() of this size pans over: twice its width, the marker a sixth of its height (BGR)."""
    w, h = size
    return scene(w * 2, h, marker_px=h // 6)
