"""The burn segmentation network: a small U-Net sized for one CPU core (training needs torch).

Encoder of five levels (3x3 conv, batch norm, ReLU, twice per level; max-pool between levels),
decoder with bilinear upsampling and skip connections, one logit per pixel. Input RGB in [0, 1],
normalised inside the network so the exported ONNX model needs no preprocessing constants.
"""

from __future__ import annotations

import torch
from torch import nn
from torch.nn import functional as F


def _block(c_in: int, c_out: int) -> nn.Sequential:
    return nn.Sequential(
        nn.Conv2d(c_in, c_out, 3, padding=1, bias=False),
        nn.BatchNorm2d(c_out),
        nn.ReLU(inplace=True),
        nn.Conv2d(c_out, c_out, 3, padding=1, bias=False),
        nn.BatchNorm2d(c_out),
        nn.ReLU(inplace=True),
    )


class BurnUNet(nn.Module):
    """U-Net; `widths` are the channel counts of the encoder levels, finest first."""

    def __init__(self, widths: tuple[int, ...] = (12, 24, 48, 96, 160)):
        super().__init__()
        self.widths = tuple(widths)
        self.down = nn.ModuleList()
        c_prev = 3
        for w in widths:
            self.down.append(_block(c_prev, w))
            c_prev = w
        self.up = nn.ModuleList(_block(widths[i + 1] + widths[i], widths[i]) for i in reversed(range(len(widths) - 1)))
        self.head = nn.Conv2d(widths[0], 1, 1)
        self.register_buffer("mean", torch.tensor([0.5, 0.5, 0.5]).view(1, 3, 1, 1))
        self.register_buffer("std", torch.tensor([0.25, 0.25, 0.25]).view(1, 3, 1, 1))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """Logits (N, 1, H, W) for RGB images (N, 3, H, W) in [0, 1]; H and W divisible by 16."""
        x = (x - self.mean) / self.std
        skips = []
        for i, block in enumerate(self.down):
            if i:
                x = F.max_pool2d(x, 2)
            x = block(x)
            skips.append(x)
        for block, skip in zip(self.up, reversed(skips[:-1]), strict=True):
            x = F.interpolate(x, size=skip.shape[-2:], mode="bilinear", align_corners=False)
            x = block(torch.cat([x, skip], dim=1))
        return self.head(x)


class Probability(nn.Module):
    """The exported graph: the network followed by a sigmoid, so ONNX gives probabilities."""

    def __init__(self, net: BurnUNet):
        super().__init__()
        self.net = net

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return torch.sigmoid(self.net(x))


class LiteUNet(nn.Module):
    """A U-Net decoder on the ImageNet-pretrained EfficientNet-Lite0 encoder (lite_encoder.py): at each of the
    encoder's strides 16, 8, 4 and 2, the upsampled features joined with the encoder's and two 3x3 convolutions;
    then the last ones upsampled to the input's size and one 1x1 convolution at full size (`full_size`
    channels: the outline's pixels are where area and perimeter are decided). Input sides: multiples of 32."""

    def __init__(self, decoder: tuple[int, ...] = (64, 40, 24, 16), full_size: int = 8, pretrained: bool = True):
        super().__init__()
        from processing.segmentation.lite_encoder import TAP_CHANNELS, LiteEncoder, load_pretrained

        self.widths = tuple(decoder)
        self.encoder = load_pretrained(LiteEncoder()) if pretrained else LiteEncoder()
        c_prev, ups = TAP_CHANNELS[-1], []
        for skip, width in zip(reversed(TAP_CHANNELS[:-1]), decoder, strict=True):
            ups.append(_block(c_prev + skip, width))
            c_prev = width
        self.up = nn.ModuleList(ups)
        self.full = nn.Sequential(
            nn.Conv2d(c_prev, full_size, 3, padding=1, bias=False), nn.BatchNorm2d(full_size), nn.ReLU(inplace=True)
        )
        self.head = nn.Conv2d(full_size, 1, 1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """Logits (N, 1, H, W) for RGB images (N, 3, H, W) in [0, 1]; H and W multiples of 32."""
        size = x.shape[-2:]
        taps = self.encoder(x)
        y = taps[-1]
        for block, skip in zip(self.up, reversed(taps[:-1]), strict=True):
            y = F.interpolate(y, size=skip.shape[-2:], mode="bilinear", align_corners=False)
            y = block(torch.cat([y, skip], dim=1))
        y = F.interpolate(y, size=size, mode="bilinear", align_corners=False)
        return self.head(self.full(y))

    def freeze_encoder(self, frozen: bool) -> None:
        """Train the decoder alone on the pretrained features (frozen: weights and batch-norm statistics kept)."""
        for p in self.encoder.parameters():
            p.requires_grad = not frozen
        self.encoder.train(not frozen and self.training)
