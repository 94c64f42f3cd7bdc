"""Training the burn segmentation model on the CPU (needs the `train` extra); resumable after every epoch.

    run(conf, real_root, out_dir, cache_dir) -> out_dir/training_report.json

Loss: L = a * soft Dice + (1 - a) * BCE, the BCE weighted up near the outline. One-cycle AdamW, batches
at several input sides. Two stages, each with its own checkpoint: the first on the photos and the phantom
burns, the second (shorter, from the first's weights) adding burns far into healing. processing.segmentation.evaluate exports, tunes and scores the result.
"""

from __future__ import annotations

import json
import logging
import time
from pathlib import Path

import cv2
import msgspec
import numpy as np
import torch
from torch.nn import functional as F

from processing.segmentation import datasets, evaluate, passes
from processing.segmentation.network import BurnUNet, LiteUNet
from processing.segmentation.scores import split_scores
from schemas.errors import InvalidInput
from schemas.segmentation import TrainingConfig

log = logging.getLogger(__name__)


def wound_square(mask: np.ndarray, rng: np.random.Generator) -> tuple[int, int, int, int]:
    """(y0, x0, height, width) of a square around the wound, tight or loose, as the fine pass sees it."""
    ys, xs = np.nonzero(mask)
    h, w = mask.shape
    extent = max(ys.max() - ys.min(), xs.max() - xs.min()) + 1
    side = int(np.clip(extent / rng.uniform(0.3, 0.9), 32, min(h, w)))
    cy = (ys.min() + ys.max()) / 2 + rng.uniform(-0.15, 0.15) * side
    cx = (xs.min() + xs.max()) / 2 + rng.uniform(-0.15, 0.15) * side
    return int(np.clip(cy - side / 2, 0, h - side)), int(np.clip(cx - side / 2, 0, w - side)), side, side


def random_crop(mask: np.ndarray, rng: np.random.Generator) -> tuple[int, int, int, int]:
    """(y0, x0, height, width) of 55-100 % of the picture at an aspect of 0.78-1.28."""
    h, w = mask.shape
    scale = rng.uniform(0.55, 1.0)
    aspect = np.exp(rng.uniform(-0.25, 0.25))
    ch, cw = int(min(h, h * scale * aspect)), int(min(w, w * scale / aspect))
    return int(rng.integers(0, h - ch + 1)), int(rng.integers(0, w - cw + 1)), ch, cw


def augment(
    sample: datasets.Sample, size: int, rng: np.random.Generator, wound_crop_share: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """A crop (around the wound, or random in scale and aspect), flips, quarter turns, exposure, colour, blur."""
    rgb, mask = sample.rgb, sample.mask
    around_wound = sample.group == "real" and mask.any() and rng.random() < wound_crop_share
    y0, x0, ch, cw = wound_square(mask, rng) if around_wound else random_crop(mask, rng)
    rgb = cv2.resize(rgb[y0 : y0 + ch, x0 : x0 + cw], (size, size), interpolation=cv2.INTER_AREA)
    mask = cv2.resize(mask[y0 : y0 + ch, x0 : x0 + cw], (size, size), interpolation=cv2.INTER_NEAREST)
    if rng.random() < 0.5:
        rgb, mask = rgb[:, ::-1], mask[:, ::-1]
    k = int(rng.integers(0, 4))
    rgb, mask = np.rot90(rgb, k), np.rot90(mask, k)
    x = rgb.astype(np.float32) / 255.0
    x = x ** np.float32(np.exp(rng.uniform(-0.3, 0.3)))  # exposure
    x = x * rng.uniform(0.8, 1.2, 3).astype(np.float32)  # white balance
    grey = x.mean(axis=2, keepdims=True)
    x = grey + (x - grey) * np.float32(rng.uniform(0.75, 1.25))  # saturation
    if rng.random() < 0.25:
        x = cv2.GaussianBlur(x, (0, 0), rng.uniform(0.5, 1.5))
    return np.clip(x, 0, 1), np.ascontiguousarray(mask)


def boundary_band(target: torch.Tensor, px: int) -> torch.Tensor:
    """1 on pixels within px of the true outline (inside or out), else 0."""
    dilated = F.max_pool2d(target, 2 * px + 1, stride=1, padding=px)
    eroded = -F.max_pool2d(-target, 2 * px + 1, stride=1, padding=px)
    return dilated - eroded


def loss_fn(logits: torch.Tensor, target: torch.Tensor, conf: TrainingConfig) -> torch.Tensor:
    """a * soft Dice + (1 - a) * BCE, the BCE weighted up near the outline."""
    p = torch.sigmoid(logits)
    inter = (p * target).sum(dim=(1, 2, 3))
    dice = 1 - (2 * inter + 1) / (p.sum(dim=(1, 2, 3)) + target.sum(dim=(1, 2, 3)) + 1)
    weight = 1 + conf.boundary_weight * boundary_band(target, conf.boundary_band_px)
    bce = F.binary_cross_entropy_with_logits(logits, target, weight=weight)
    a = conf.dice_weight
    return a * dice.mean() + (1 - a) * bce


PRETRAINED_STRIDE = 32
"""The pretrained encoder halves the side five times: every side it sees is a multiple of this."""


def build_network(conf: TrainingConfig) -> BurnUNet | LiteUNet:
    """The recipe's network, its encoder pretrained where the recipe says so."""
    if conf.encoder == "plain":
        return BurnUNet(tuple(conf.widths))
    sides = {conf.input_size, *conf.scales, *conf.coarse_sizes}
    if odd := sorted(s for s in sides if s % PRETRAINED_STRIDE):
        raise InvalidInput(
            f"{conf.encoder} needs sides that are multiples of {PRETRAINED_STRIDE}: {odd} are not (input_size, "
            "scales, coarse_sizes)"
        )
    return LiteUNet(tuple(conf.decoder_widths))


def optimiser(net: BurnUNet | LiteUNet, conf: TrainingConfig, learning_rate: float):
    """AdamW and its one-cycle peaks: the pretrained encoder at encoder_learning_rate_scale of the rest."""
    if not isinstance(net, LiteUNet):
        return torch.optim.AdamW(net.parameters(), lr=learning_rate, weight_decay=conf.weight_decay), learning_rate
    encoder = list(net.encoder.parameters())
    mine = {id(p) for p in encoder}
    rest = [p for p in net.parameters() if id(p) not in mine]
    peaks = [learning_rate * conf.encoder_learning_rate_scale, learning_rate]
    groups = [{"params": encoder, "lr": peaks[0]}, {"params": rest, "lr": peaks[1]}]
    return torch.optim.AdamW(groups, weight_decay=conf.weight_decay), peaks


def training_device() -> torch.device:
    """A GPU where torch finds one (faster; never needed), else the CPU."""
    return torch.device("cuda" if torch.cuda.is_available() else "cpu")


def device_of(net: torch.nn.Module) -> torch.device:
    return next(net.parameters()).device


def torch_network(net: BurnUNet):
    """The network as processing.segmentation.passes calls it: NCHW float32 in, (N, H, W) probability out."""

    def network(x: np.ndarray) -> np.ndarray:
        with torch.no_grad():
            return torch.sigmoid(net(torch.from_numpy(x).to(device_of(net))))[:, 0].cpu().numpy()

    return network


def single_pass_dice(net: BurnUNet, samples: list[datasets.Sample], size: int) -> float:
    """Pooled Dice of one pass over each whole image at threshold 0.5: the curve logged while training."""
    net.eval()
    network = torch_network(net)
    pairs = [(passes.run_network(network, s.rgb, size) >= 0.5, s.mask.astype(bool)) for s in samples]
    return split_scores(pairs).dice_pooled or 0.0


def batches(pool: list[datasets.Sample], conf: TrainingConfig, rng: np.random.Generator):
    """Shuffled batches, each at one of conf.scales."""
    order = rng.permutation(len(pool))
    for i in range(0, len(order) - conf.batch_size + 1, conf.batch_size):
        size = int(rng.choice(conf.scales))
        pairs = [augment(pool[j], size, rng, conf.wound_crop_share) for j in order[i : i + conf.batch_size]]
        x = torch.from_numpy(np.stack([p[0] for p in pairs])).permute(0, 3, 1, 2).contiguous()
        y = torch.from_numpy(np.stack([p[1] for p in pairs]).astype(np.float32))[:, None]
        yield x, y


def stage_recipe(conf: TrainingConfig, stage: int) -> str:
    """The recipe a stage's checkpoint is bound to: the first stage's leaves the healed stage out, so a
    change to the second stage does not throw the first away."""
    if stage == 2:
        return msgspec.json.encode(conf).decode()
    first = msgspec.to_builtins(conf)
    first.pop("healed_stage")
    return msgspec.json.encode(first).decode()


class Checkpoint:
    """Everything a stopped stage needs to go on exactly where it was: weights, optimiser, schedule,
    random states, the curves and the time spent. Written whole after every epoch, then moved in place."""

    def __init__(self, path: Path, recipe: str):
        self.path, self.recipe = path, recipe

    def save(self, net, opt, sched, rng: np.random.Generator, state: dict) -> None:
        tmp = self.path.with_name(self.path.name + ".tmp")
        torch.save(
            {
                "recipe": self.recipe,
                "model": net.state_dict(),
                "optimizer": opt.state_dict(),
                "scheduler": sched.state_dict(),
                "numpy_rng": rng.bit_generator.state,
                "torch_rng": torch.get_rng_state(),
                **state,
            },
            tmp,
        )
        tmp.replace(self.path)

    def load(self, net, opt, sched, rng: np.random.Generator) -> dict:
        """The saved progress ({} when there is no checkpoint); refuses one made with another recipe."""
        if not self.path.exists():
            return {}
        saved = torch.load(self.path, weights_only=False, map_location=device_of(net))
        if saved["recipe"] != self.recipe:
            raise InvalidInput(
                f"{self.path} was made with another recipe; continue it with that recipe, or train into "
                "another --out folder"
            )
        net.load_state_dict(saved["model"])
        opt.load_state_dict(saved["optimizer"])
        sched.load_state_dict(saved["scheduler"])
        rng.bit_generator.state = saved["numpy_rng"]
        torch.set_rng_state(saved["torch_rng"].cpu())
        return {k: saved[k] for k in ("epoch", "loss_history", "tune_history", "train_seconds")}


def _run_stage(
    net: BurnUNet,
    conf: TrainingConfig,
    stage: tuple[int, int, float],
    pools: tuple[list, list, list],
    checkpoint: Checkpoint,
    state: dict,
    stop_after: int,
    deadline: float | None = None,
) -> dict:
    """Runs one stage from its checkpoint (or from `state` and the weights net has) to its last epoch or
    stop_after epochs in all. stage: (first epoch, last epoch, peak learning rate), counted over both
    stages; pools: the real training photos, the phantom crops and the tuning photos."""
    first, last, learning_rate = stage
    real_train, syn_train, real_tune = pools
    rng = np.random.default_rng(conf.seed if first == 0 else [conf.seed, first])
    per_epoch = (len(real_train) + min(conf.synthetic_per_epoch, len(syn_train))) // conf.batch_size
    if per_epoch == 0:
        raise InvalidInput(
            f"too little training data: {len(real_train)} photos and {len(syn_train)} phantom crops "
            f"make no batch of {conf.batch_size}"
        )
    opt, peaks = optimiser(net, conf, learning_rate)
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, peaks, total_steps=per_epoch * (last - first), pct_start=0.1)
    state = state | checkpoint.load(net, opt, sched, rng)
    if state["epoch"] > first:
        log.info("continuing %s after epoch %d of %d", checkpoint.path, state["epoch"], last)
    # A new stage or a continued run has timed no epoch yet: the mean so far stands in for the next one.
    epoch_seconds = state["train_seconds"] / state["epoch"] if state["epoch"] else 0.0
    while state["epoch"] < min(last, stop_after):
        started = time.monotonic()
        if deadline is not None and started + epoch_seconds > deadline:
            log.info("stopping before epoch %d: it would end past this run's time limit", state["epoch"] + 1)
            break
        net.train()
        if isinstance(net, LiteUNet):
            net.freeze_encoder(state["epoch"] < conf.frozen_encoder_epochs)
        picked = rng.choice(len(syn_train), min(conf.synthetic_per_epoch, len(syn_train)), replace=False)
        losses = []
        for step, (x, y) in enumerate(batches(real_train + [syn_train[i] for i in picked], conf, rng)):
            if step >= per_epoch:
                break
            x, y = x.to(device_of(net)), y.to(device_of(net))
            loss = loss_fn(net(x), y, conf)
            opt.zero_grad()
            loss.backward()
            opt.step()
            sched.step()
            losses.append(loss.item())
        state["epoch"] += 1
        state["loss_history"].append(round(float(np.mean(losses)), 5))
        state["tune_history"].append(single_pass_dice(net, real_tune, conf.input_size))
        epoch_seconds = time.monotonic() - started
        state["train_seconds"] += epoch_seconds
        log.info(
            "epoch %d/%d loss %.4f, tuning Dice %.3f (%.0f s in all)",
            state["epoch"],
            last,
            state["loss_history"][-1],
            state["tune_history"][-1],
            state["train_seconds"],
        )
        checkpoint.save(net, opt, sched, rng, state)
        write_curve(checkpoint.path.parent / "curve.json", state)
    return state


def write_curve(path: Path, state: dict) -> None:
    """The training curve as it stands (loss, tuning Dice, seconds): small enough to commit, unlike weights."""
    keys = ("epoch", "loss_history", "tune_history", "train_seconds")
    path.write_text(json.dumps({k: state[k] for k in keys}, indent=1) + "\n")


def train(
    conf: TrainingConfig,
    real: dict,
    synthetic: dict,
    out_dir: Path,
    stop_after: int | None = None,
    healed: list[datasets.Sample] = (),
    deadline: float | None = None,
) -> tuple[BurnUNet, dict]:
    """Trains (or continues a stopped run in out_dir) and returns the network and its progress: the first
    stage on the photos and synthetic["train"], then the healed stage, if the recipe has one, adding the
    `healed` phantom crops. stop_after ends this run after that many epochs in all (the checkpoints
    continue it later)."""
    torch.manual_seed(conf.seed)
    torch.set_num_threads(conf.threads)
    net = build_network(conf).to(training_device())
    out_dir.mkdir(parents=True, exist_ok=True)
    state = {"epoch": 0, "loss_history": [], "tune_history": [], "train_seconds": 0.0}
    healed_stage = conf.healed_stage
    total = conf.epochs + (healed_stage.epochs if healed_stage else 0)
    stop_after = min(stop_after or total, total)
    pools = (real["train"], synthetic["train"], real["tune"])
    first = Checkpoint(out_dir / "checkpoint.pt", stage_recipe(conf, 1))
    second = Checkpoint(out_dir / "checkpoint_healed.pt", stage_recipe(conf, 2))
    first_done = bool(healed_stage and second.path.exists())
    if not first_done:
        state = _run_stage(net, conf, (0, conf.epochs, conf.learning_rate), pools, first, state, stop_after, deadline)
        first_done = state["epoch"] >= conf.epochs  # not when the run's time ended it
    if healed_stage and stop_after > conf.epochs and first_done:
        pools = (real["train"], synthetic["train"] + list(healed), real["tune"])
        stage = (conf.epochs, total, healed_stage.learning_rate)
        state = _run_stage(net, conf, stage, pools, second, state, stop_after, deadline)
    net.eval()
    return net, state


def run(
    conf: TrainingConfig, real_root: Path, out_dir: Path, cache_dir: Path, max_minutes: float | None = None
) -> Path:
    """Trains, then evaluates and writes the model and its report; with max_minutes, stops before an epoch that
    would end later and returns the checkpoint's curve instead (run it again to go on)."""
    deadline = time.monotonic() + max_minutes * 60 if max_minutes else None
    out_dir.mkdir(parents=True, exist_ok=True)
    real = datasets.real_samples(real_root, conf.validation_percent, conf.tune_percent)
    scenes = datasets.render_scenes(conf, cache_dir)
    first = conf.synthetic_scenes
    synthetic = datasets.synthetic_samples(scenes[:first], conf)
    healed = datasets.synthetic_samples(scenes[first:], conf, first_index=first)
    log.info(
        "real photos %s; phantom crops %s, healed stage %s",
        {k: len(v) for k, v in real.items()},
        {k: len(v) for k, v in synthetic.items()},
        {k: len(v) for k, v in healed.items()},
    )
    net, state = train(conf, real, synthetic, out_dir, healed=healed["train"], deadline=deadline)
    total = conf.epochs + (conf.healed_stage.epochs if conf.healed_stage else 0)
    if state["epoch"] < total:
        log.info("stopped after epoch %d of %d: run the same command again to continue", state["epoch"], total)
        return out_dir / "curve.json"
    both = {k: synthetic[k] + healed[k] for k in synthetic}
    return evaluate.run(conf, net.cpu(), state, real, both, out_dir)  # exported and scored as the clinic runs it
