"""Running the burn segmentation model with onnxruntime on the CPU.

The model sees a square: a crop around where the burn is expected (from the reconstruction) or
the whole picture, resized to its input side; its probabilities are resized back and pasted in.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import onnxruntime as ort

from schemas.errors import InvalidInput, plain

SHIPPED_MODEL = Path(__file__).parent / "models" / "burnseg.onnx"


def read_rgb(path: Path) -> np.ndarray:
    """A photo's pixels as stored (EXIF orientation not applied, as in the analysis), RGB uint8."""
    from PIL import Image, UnidentifiedImageError
    from pillow_heif import register_heif_opener

    register_heif_opener()
    try:
        with Image.open(path) as image:
            return np.asarray(image.convert("RGB"))
    except (OSError, UnidentifiedImageError) as exc:
        raise InvalidInput(f"{path.name} could not be decoded as a photo ({plain(exc)})") from exc


@dataclass(frozen=True)
class Box:
    """A square region of a picture in pixels: x0, y0 inclusive, side."""

    x0: int
    y0: int
    side: int

    @classmethod
    def around(cls, cx: float, cy: float, radius: float, width: int, height: int) -> Box:
        """The square of half-side radius centred on (cx, cy), moved (not shrunk) to fit in the picture."""
        side = int(min(2 * radius, width, height))
        x0 = int(np.clip(round(cx - side / 2), 0, width - side))
        y0 = int(np.clip(round(cy - side / 2), 0, height - side))
        return cls(x0, y0, side)


class BurnSegmenter:
    """One onnxruntime session; `probability` is safe to call repeatedly (not from several threads)."""

    def __init__(self, model: str | Path = "", threads: int = 1):
        path = Path(model) if model else SHIPPED_MODEL
        if not path.is_file():
            raise InvalidInput(f"segmentation model {path} not found; set [analysis] model to an ONNX file")
        options = ort.SessionOptions()
        options.intra_op_num_threads = threads
        options.inter_op_num_threads = 1
        try:
            self.session = ort.InferenceSession(str(path), options, providers=["CPUExecutionProvider"])
        except Exception as exc:  # onnxruntime raises its own untyped errors for unreadable models
            raise InvalidInput(f"segmentation model {path} cannot be loaded: {exc}") from exc
        meta = self.session.get_modelmeta().custom_metadata_map
        self.input_size = int(meta.get("input_size", "192"))
        self.path = path

    def _run(self, rgb: np.ndarray) -> np.ndarray:
        x = cv2.resize(rgb, (self.input_size, self.input_size), interpolation=cv2.INTER_AREA)
        x = np.ascontiguousarray(x.transpose(2, 0, 1)[None], dtype=np.float32) / 255.0
        return self.session.run(None, {"image": x})[0][0, 0]

    def probability(self, rgb: np.ndarray, box: Box | None = None) -> np.ndarray:
        """Burn probability (H, W) float32 for an RGB uint8 picture; 0 outside the box when one is given."""
        if rgb.ndim != 3 or rgb.shape[2] != 3 or rgb.dtype != np.uint8:
            raise InvalidInput(f"expected an RGB uint8 picture, got shape {rgb.shape} {rgb.dtype}")
        h, w = rgb.shape[:2]
        if box is None:
            return cv2.resize(self._run(rgb), (w, h), interpolation=cv2.INTER_LINEAR)
        out = np.zeros((h, w), np.float32)
        crop = rgb[box.y0 : box.y0 + box.side, box.x0 : box.x0 + box.side]
        out[box.y0 : box.y0 + box.side, box.x0 : box.x0 + box.side] = cv2.resize(
            self._run(crop), (box.side, box.side), interpolation=cv2.INTER_LINEAR
        )
        return out
