"""Training data for the burn segmentation model: real wound photos and rendered phantom burns.

Real: FUSeg 2021 foot-ulcer photos with wound masks (../shared/datasets/fuseg2021-train). A hash of the
file name puts each photo in the validation split (never trained or tuned on), the tuning split (chooses
the threshold and the passes) or training, so the splits never change.
Synthetic: phantom scenes rendered by `processing.phantom` across skin types, burn looks, body parts,
healing and crater depth; every fifth scene is held out whole and every tenth from the sixth on is kept
for tuning (no view of either is trained on). The second training stage's scenes follow on from the
first's in the same numbering, far into healing.
"""

from __future__ import annotations

import hashlib
import logging
from dataclasses import dataclass
from pathlib import Path

import cv2
import msgspec
import numpy as np

from processing.phantom.generate import run as render_phantom
from processing.reconstruction.views import read_rgb
from schemas.errors import InvalidInput
from schemas.phantom import BurnLook, PhantomShape, PhantomSpec, SkinTone
from schemas.segmentation import TrainingConfig

log = logging.getLogger(__name__)

TONES = list(SkinTone)
LOOKS = list(BurnLook)
SHAPES = list(PhantomShape)


@dataclass(frozen=True)
class Sample:
    """One training or validation image with its burn mask (uint8 RGB, uint8 0/1)."""

    rgb: np.ndarray
    mask: np.ndarray
    group: str
    """'real', or the skin type of a phantom crop."""
    name: str


def _bucket(name: str) -> int:
    return int(hashlib.sha256(name.encode()).hexdigest()[:8], 16) % 100


def is_validation(name: str, percent: int) -> bool:
    return _bucket(name) < percent


def real_split(name: str, validation_percent: int, tune_percent: int) -> str:
    """'validation', 'tune' or 'train' for a photo, by a hash of its file name."""
    bucket = _bucket(name)
    if bucket < validation_percent:
        return "validation"
    return "tune" if bucket < validation_percent + tune_percent else "train"


def scene_split(index: int) -> str:
    """'validation' (every fifth scene), 'tune' (every tenth from the fourth on) or 'train'."""
    if index % 5 == 0:
        return "validation"
    return "tune" if index % 10 == 3 else "train"


def read_mask(path: Path) -> np.ndarray:
    mask = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    if mask is None:
        raise InvalidInput(f"{path}: not a readable mask")
    return (mask >= 128).astype(np.uint8)


def real_samples(root: Path, percent: int, tune_percent: int = 0) -> dict[str, list[Sample]]:
    """{'train', 'tune', 'validation'} photos from a folder with images/ and masks/ of the same stems."""
    images = sorted((root / "images").glob("*.jpg")) + sorted((root / "images").glob("*.png"))
    if not images:
        raise InvalidInput(f"{root}: no images/ with .jpg or .png photos; is the dataset there?")
    splits: dict[str, list[Sample]] = {"train": [], "tune": [], "validation": []}
    for image in images:
        mask = root / "masks" / f"{image.stem}.png"
        if not mask.exists():
            raise InvalidInput(f"{image}: no mask {mask}")
        sample = Sample(read_rgb(image), read_mask(mask), "real", image.name)
        splits[real_split(image.name, percent, tune_percent)].append(sample)
    return splits


def scene_count(conf: TrainingConfig) -> int:
    """Scenes of both stages: the first stage's come first."""
    return conf.synthetic_scenes + (conf.healed_stage.scenes if conf.healed_stage else 0)


def phantom_spec(index: int, conf: TrainingConfig) -> PhantomSpec:
    """The index-th training scene: tones and looks come round in turn, the body part is drawn at random;
    from conf.synthetic_scenes on, the healed stage's scenes, drawn the same way but far into healing."""
    rng = np.random.default_rng([conf.seed, index])
    spec = PhantomSpec(
        shape=SHAPES[int(rng.integers(0, len(SHAPES)))],
        seed=int(rng.integers(1, 2**31)),
        views=conf.synthetic_views,
        width=640,
        height=480,
        supersample=1.0,
        tone=TONES[index % len(TONES)],
        burn_look=LOOKS[(index // len(TONES)) % len(LOOKS)],
        area_cm2=float(rng.uniform(2.0, 40.0)),
        depth_mm=float(rng.choice([0.0, rng.uniform(0.5, 4.0)])),
        healing=float(rng.choice([0.0, rng.uniform(0.0, 0.6)])),
        distance_min_mm=150.0,
        distance_max_mm=300.0,
        jpeg_quality=int(rng.integers(70, 95)),
    )
    stage = conf.healed_stage
    if index < conf.synthetic_scenes or stage is None:
        return spec
    return msgspec.structs.replace(spec, healing=float(rng.uniform(stage.healing_min, stage.healing_max)))


def render_scenes(conf: TrainingConfig, cache: Path) -> list[tuple[Path, PhantomSpec]]:
    """Renders the training scenes into cache/ (scenes already there are kept)."""
    scenes = []
    for index in range(scene_count(conf)):
        spec = phantom_spec(index, conf)
        digest = hashlib.sha256(msgspec.json.encode(spec)).hexdigest()[:10]
        folder = cache / f"scene_{index:03d}_{digest}"
        if not (folder / "ground_truth.json").exists():
            log.info(
                "rendering phantom %d/%d (%s, tone %s, %s)",
                index + 1,
                scene_count(conf),
                spec.shape,
                spec.tone,
                spec.burn_look,
            )
            render_phantom(spec, folder)
        scenes.append((folder, spec))
    return scenes


def burn_crops(rgb: np.ndarray, mask: np.ndarray, rng: np.random.Generator, count: int, size: int):
    """Square crops around the burn, from tight (burn fills most of it) to loose, resized to size."""
    ys, xs = np.nonzero(mask)
    h, w = mask.shape
    if len(ys) < 20:
        return
    extent = max(ys.max() - ys.min(), xs.max() - xs.min()) + 1
    for _ in range(count):
        side = int(np.clip(extent / rng.uniform(0.25, 0.85), 32, min(h, w)))
        cy = (ys.min() + ys.max()) / 2 + rng.uniform(-0.2, 0.2) * side
        cx = (xs.min() + xs.max()) / 2 + rng.uniform(-0.2, 0.2) * side
        y0 = int(np.clip(cy - side / 2, 0, h - side))
        x0 = int(np.clip(cx - side / 2, 0, w - side))
        crop = rgb[y0 : y0 + side, x0 : x0 + side]
        crop_mask = mask[y0 : y0 + side, x0 : x0 + side]
        yield (
            cv2.resize(crop, (size, size), interpolation=cv2.INTER_AREA),
            cv2.resize(crop_mask, (size, size), interpolation=cv2.INTER_NEAREST),
        )


def synthetic_samples(
    scenes: list[tuple[Path, PhantomSpec]], conf: TrainingConfig, crops_per_view: int = 3, first_index: int = 0
) -> dict[str, list[Sample]]:
    """{'train', 'tune', 'validation'} crops around each view's burn; a scene kept out of training gives one
    loose crop per view, as the analysis's region around the burn would be. `first_index`: the number of
    scenes[0] in the whole series, which sets its split."""
    splits: dict[str, list[Sample]] = {"train": [], "tune": [], "validation": []}
    size = conf.input_size * 2  # kept at twice the input so augmentation can rescale
    for index, (folder, spec) in enumerate(scenes, start=first_index):
        rng = np.random.default_rng([conf.seed, 7, index])
        split = scene_split(index)
        count = crops_per_view if split == "train" else 1
        for image in sorted((folder / "images").glob("*.jpg")):
            rgb, mask = read_rgb(image), read_mask(folder / "masks" / f"{image.stem}.png")
            for k, (crop, crop_mask) in enumerate(burn_crops(rgb, mask, rng, count, size)):
                splits[split].append(Sample(crop, crop_mask, spec.tone.value, f"{folder.name}/{image.stem}#{k}"))
    return splits
