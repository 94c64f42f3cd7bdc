"""Running the burn segmentation model with onnxruntime on the CPU.

The model looks twice (processing/segmentation/passes.py): over the square around where the burn is
expected (from the reconstruction) or the whole picture, then closer over a square around the burn it
found. How it runs (sides, threshold) is in the model file's metadata, chosen when it was trained.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import msgspec
import numpy as np
import onnxruntime as ort

from processing.segmentation import passes
from processing.segmentation.passes import Square as Box
from processing.segmentation.passes import TwoPass
from schemas.errors import InvalidInput, plain
from schemas.segmentation import FairnessTable, PassSettings

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


def settings_of(meta: dict[str, str]) -> PassSettings:
    """The passes a model file asks for; a model from before the second pass runs one pass at 0.5."""
    size = int(meta.get("input_size", "192"))
    try:
        return PassSettings(
            coarse_size=int(meta.get("coarse_size", size)),
            fine_size=size,
            threshold=float(meta.get("threshold", "0.5")),
            fine_pass=meta.get("fine_pass", "false") == "true",
        )
    except ValueError as exc:
        raise InvalidInput(
            f"the segmentation model's metadata is not understood ({exc}); retrain or re-export it"
        ) from exc


def fairness_of(meta: dict[str, str]) -> FairnessTable | None:
    """The held-out Dice by skin tone a model file carries; None for a model from before it was measured,
    or one stamped with another table layout (its fairness is not known here)."""
    try:
        return msgspec.json.decode(meta["fairness"], type=FairnessTable) if "fairness" in meta else None
    except msgspec.ValidationError:
        return None


class BurnSegmenter:
    """One onnxruntime session; safe to call repeatedly (not from several threads)."""

    def __init__(self, model: str | Path = "", threads: int = 1, settings: PassSettings | None = None):
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
        self.metadata = dict(self.session.get_modelmeta().custom_metadata_map)
        self.sha256 = hashlib.sha256(path.read_bytes()).hexdigest()
        self.settings = settings or settings_of(self.metadata)
        self.path = path

    def network(self, x: np.ndarray) -> np.ndarray:
        """Probability (N, H, W) for float32 NCHW RGB in [0, 1]."""
        return self.session.run(None, {"image": x})[0][:, 0]

    def segment(self, rgb: np.ndarray, region: Box | None = None) -> TwoPass:
        """Both passes over an RGB uint8 picture (region None: the whole picture)."""
        if rgb.ndim != 3 or rgb.shape[2] != 3 or rgb.dtype != np.uint8:
            raise InvalidInput(f"expected an RGB uint8 picture, got shape {rgb.shape} {rgb.dtype}")
        return passes.segment(self.network, rgb, region, self.settings)

    def probability(self, rgb: np.ndarray, region: Box | None = None) -> np.ndarray:
        """Burn probability (H, W) float32, rescaled so burn is >= 0.5 whatever threshold the model was
        tuned to; 0 outside what the passes looked at."""
        two = self.segment(rgb, region)
        return passes.rescaled(two.probability, self.settings.threshold, two.looked_at(), in_place=True)
