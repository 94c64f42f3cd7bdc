"""Training the burn segmentation model on the CPU and exporting it to ONNX (needs the `train` extra).

    run(conf, real_root, out_dir, cache_dir) -> out_dir/training_report.json

Loss: L = a * soft Dice + (1 - a) * BCE (the seed's). One-cycle AdamW. Scores are measured on the
held-out real photos at their own resolution and on held-out phantom scenes per skin type.
"""

from __future__ import annotations

import hashlib
import logging
import os
import platform
import time
from pathlib import Path

import cv2
import msgspec
import numpy as np
import torch
from torch.nn import functional as F

from processing.segmentation import datasets
from processing.segmentation.network import BurnUNet, Probability
from processing.segmentation.scores import split_scores
from processing.stages import write_json
from schemas.errors import InvalidInput
from schemas.segmentation import TrainingConfig, TrainingReport

log = logging.getLogger(__name__)

MODEL = "burnseg.onnx"
REPORT = "training_report.json"


def augment(sample: datasets.Sample, size: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A random crop (scale and aspect), flips, quarter turns, exposure, colour and blur."""
    rgb, mask = sample.rgb, sample.mask
    h, w = mask.shape
    scale = rng.uniform(0.55, 1.0)
    aspect = np.exp(rng.uniform(-0.25, 0.25))
    ch, cw = int(min(h, h * scale * aspect)), int(min(w, w * scale / aspect))
    y0, x0 = int(rng.integers(0, h - ch + 1)), int(rng.integers(0, w - cw + 1))
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


def loss_fn(logits: torch.Tensor, target: torch.Tensor, a: float) -> torch.Tensor:
    p = torch.sigmoid(logits)
    inter = (p * target).sum(dim=(1, 2, 3))
    dice = 1 - (2 * inter + 1) / (p.sum(dim=(1, 2, 3)) + target.sum(dim=(1, 2, 3)) + 1)
    return a * dice.mean() + (1 - a) * F.binary_cross_entropy_with_logits(logits, target)


def predict(net: BurnUNet, rgb: np.ndarray, size: int) -> np.ndarray:
    """Burn probability at the image's own resolution (the whole image resized to the input)."""
    x = cv2.resize(rgb, (size, size), interpolation=cv2.INTER_AREA).astype(np.float32) / 255.0
    with torch.no_grad():
        p = torch.sigmoid(net(torch.from_numpy(x).permute(2, 0, 1)[None]))[0, 0].numpy()
    return cv2.resize(p, (rgb.shape[1], rgb.shape[0]), interpolation=cv2.INTER_LINEAR)


def evaluate(net: BurnUNet, samples: list[datasets.Sample], size: int):
    net.eval()
    return split_scores([(predict(net, s.rgb, size) >= 0.5, s.mask.astype(bool)) for s in samples])


def batches(pool: list[datasets.Sample], conf: TrainingConfig, rng: np.random.Generator):
    order = rng.permutation(len(pool))
    for i in range(0, len(order) - conf.batch_size + 1, conf.batch_size):
        pairs = [augment(pool[j], conf.input_size, rng) for j in order[i : i + conf.batch_size]]
        x = torch.from_numpy(np.stack([p[0] for p in pairs])).permute(0, 3, 1, 2).contiguous()
        y = torch.from_numpy(np.stack([p[1] for p in pairs]).astype(np.float32))[:, None]
        yield x, y


def export(net: BurnUNet, conf: TrainingConfig, path: Path) -> None:
    import onnx

    net.eval()
    dummy = torch.rand(1, 3, conf.input_size, conf.input_size)
    tmp = path.with_name(path.name + ".tmp")
    torch.onnx.export(
        Probability(net),
        dummy,
        str(tmp),
        input_names=["image"],
        output_names=["probability"],
        dynamic_axes={"image": {0: "n"}, "probability": {0: "n"}},
        opset_version=17,
        dynamo=False,
    )
    model = onnx.load(str(tmp))
    meta = {
        "input_size": str(conf.input_size),
        "input": "RGB float32 in [0, 1], NCHW",
        "output": "burn probability per pixel",
        "license": "CC BY-NC 4.0 (trained on FUSeg 2021 photos)",
        "card": "docs/segmentation-model.md",
    }
    for key, value in meta.items():
        model.metadata_props.add(key=key, value=value)
    onnx.save(model, str(tmp))
    tmp.replace(path)  # a crash never leaves a half-written model where a good one was


def run(conf: TrainingConfig, real_root: Path, out_dir: Path, cache_dir: Path) -> Path:
    torch.manual_seed(conf.seed)
    torch.set_num_threads(conf.threads)
    rng = np.random.default_rng(conf.seed)
    out_dir.mkdir(parents=True, exist_ok=True)
    real_train, real_val = datasets.real_samples(real_root, conf.validation_percent)
    syn_train, syn_val = datasets.synthetic_samples(datasets.render_scenes(conf, cache_dir), conf)
    log.info(
        "real %d train / %d held out; synthetic %d train / %d held out",
        len(real_train),
        len(real_val),
        len(syn_train),
        len(syn_val),
    )
    net = BurnUNet(tuple(conf.widths))
    per_epoch = (len(real_train) + min(conf.synthetic_per_epoch, len(syn_train))) // conf.batch_size
    if per_epoch == 0:
        raise InvalidInput(
            f"too little training data: {len(real_train)} photos and {len(syn_train)} phantom crops "
            f"make no batch of {conf.batch_size}"
        )
    opt = torch.optim.AdamW(net.parameters(), lr=conf.learning_rate, weight_decay=conf.weight_decay)
    sched = torch.optim.lr_scheduler.OneCycleLR(
        opt, conf.learning_rate, total_steps=per_epoch * conf.epochs, pct_start=0.1
    )
    history, started = [], time.monotonic()
    for epoch in range(conf.epochs):
        net.train()
        extra = (
            [
                syn_train[i]
                for i in rng.choice(len(syn_train), min(conf.synthetic_per_epoch, len(syn_train)), replace=False)
            ]
            if syn_train
            else []
        )
        losses = []
        for step, (x, y) in enumerate(batches(real_train + extra, conf, rng)):
            if step >= per_epoch:
                break
            loss = loss_fn(net(x), y, conf.dice_weight)
            opt.zero_grad()
            loss.backward()
            opt.step()
            sched.step()
            losses.append(loss.item())
        history.append(float(np.mean(losses)))
        log.info("epoch %d/%d loss %.4f (%.0f s)", epoch + 1, conf.epochs, history[-1], time.monotonic() - started)
        torch.save(net.state_dict(), out_dir / "checkpoint.pt")
    train_seconds = time.monotonic() - started
    model_path = out_dir / MODEL
    export(net, conf, model_path)
    by_tone = {
        tone.value: evaluate(net, [s for s in syn_val if s.group == tone.value], conf.input_size)
        for tone in datasets.TONES
    }
    report = TrainingReport(
        config=conf,
        model_file=MODEL,
        model_sha256=hashlib.sha256(model_path.read_bytes()).hexdigest(),
        parameters=sum(p.numel() for p in net.parameters()),
        epochs_run=conf.epochs,
        train_seconds=round(train_seconds, 1),
        machine=f"{platform.processor() or platform.machine()}, {conf.threads} of {os.cpu_count()} threads",
        real_train_images=len(real_train),
        real_validation=evaluate(net, real_val, conf.input_size),
        synthetic_train_crops=len(syn_train),
        synthetic_validation=evaluate(net, syn_val, conf.input_size),
        synthetic_by_tone=by_tone,
        loss_history=[round(v, 5) for v in history],
    )
    write_json(out_dir / REPORT, msgspec.to_builtins(report))
    return out_dir / REPORT
