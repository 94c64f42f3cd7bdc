"""Burn segmentation: the training recipe, its held-out scores, and where each view's mask came from."""

from __future__ import annotations

import enum
from typing import Annotated

import msgspec

from schemas.base import Frozen, Message


class TrainingConfig(Message):
    """Everything `burnedge train-segmentation` reads; the same config and data give the same model."""

    seed: int = 20261122
    """Seeds the split-independent randomness: weights, crops, augmentation, sampling."""
    input_size: Annotated[int, msgspec.Meta(ge=64, le=1024, multiple_of=16)] = 192
    """Side of the square network input in pixels (views are resized or cropped to it)."""
    widths: list[Annotated[int, msgspec.Meta(ge=4, le=512)]] = msgspec.field(
        default_factory=lambda: [12, 24, 48, 96, 160]
    )
    """Channels of the U-Net's encoder levels, finest first (5 levels: inputs divisible by 16)."""
    epochs: Annotated[int, msgspec.Meta(ge=1)] = 36
    """Passes over the real photos' training split."""
    synthetic_per_epoch: Annotated[int, msgspec.Meta(ge=0)] = 250
    """Rendered burn crops drawn into each epoch beside the real photos."""
    batch_size: Annotated[int, msgspec.Meta(ge=1)] = 8
    """Images per optimiser step."""
    learning_rate: Annotated[float, msgspec.Meta(gt=0)] = 3e-3
    """Peak AdamW learning rate (one-cycle schedule: warm-up, then cosine decay)."""
    weight_decay: Annotated[float, msgspec.Meta(ge=0)] = 1e-4
    """AdamW weight decay."""
    dice_weight: Annotated[float, msgspec.Meta(ge=0, le=1)] = 0.5
    """a in the loss L = a * Dice + (1 - a) * BCE (the seed's loss)."""
    validation_percent: Annotated[int, msgspec.Meta(ge=5, le=50)] = 15
    """Share of the real photos held out for validation, chosen by a hash of the file name (never trained on)."""
    synthetic_scenes: Annotated[int, msgspec.Meta(ge=0)] = 72
    """Phantom scenes rendered for training data (every fifth one is held out for validation)."""
    synthetic_views: Annotated[int, msgspec.Meta(ge=6, le=20)] = 6
    """Views rendered per phantom scene."""
    threads: Annotated[int, msgspec.Meta(ge=1)] = 2
    """CPU threads torch may use."""


class SplitScores(Frozen):
    """Dice and IoU of one held-out group, pooled over its pixels and averaged per image."""

    images: int
    """Held-out images in the group (the scores are None when there are none)."""
    dice_pooled: float | None
    """2|P∩T| / (|P| + |T|) over all the group's pixels together."""
    iou_pooled: float | None
    """|P∩T| / |P∪T| over all the group's pixels together."""
    dice_mean: float | None
    """Mean of the per-image Dice (an image with no burn in truth and prediction counts 1)."""
    iou_mean: float | None
    """Mean of the per-image IoU."""


class TrainingReport(Frozen):
    """What training produced and how the model scores on data it never saw."""

    config: TrainingConfig
    model_file: str
    """ONNX file name, beside this report."""
    model_sha256: str
    parameters: int
    """Trainable parameters."""
    epochs_run: int
    train_seconds: float
    machine: str
    """CPU and thread count it trained on."""
    real_train_images: int
    real_validation: SplitScores
    """Held-out FUSeg 2021 foot-ulcer photos, scored at their own resolution (512 x 512)."""
    synthetic_train_crops: int
    synthetic_validation: SplitScores
    """Held-out phantom scenes (crops around the burn)."""
    synthetic_by_tone: dict[str, SplitScores]
    """Held-out phantom crops per skin type I-VI."""
    loss_history: list[float]
    """Mean training loss per epoch."""


class MaskSource(enum.StrEnum):
    """Who drew a view's burn mask: the model, or a person (who always wins)."""

    model = "model"
    clinician_mask = "clinician_mask"
    """A mask image provided by a person."""
    clinician_outline = "clinician_outline"
    """An outline polygon provided by a person, filled."""
