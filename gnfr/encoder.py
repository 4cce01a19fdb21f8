"""ResUNet feature encoder (GNT/IBRNet): images -> feature maps at 1/4 resolution.

7x7 stride-2 stem, three ResNet BasicBlock stages (each stride 2), a UNet decoder with skip
connections back up to 1/4 resolution and a 1x1 output conv. InstanceNorm, reflect padding.
Widths and block counts are configurable so CPU presets can use a small encoder; ``dec_norm``
adds GNT's InstanceNorm after the decoder's two skip-merging convolutions (off in the
weights shipped so far, which were trained without it).
"""

from __future__ import annotations

import torch
import torch.nn as nn
import torch.nn.functional as F


def _norm(ch: int) -> nn.Module:
    return nn.InstanceNorm2d(ch, affine=True, track_running_stats=False)


def _conv(cin: int, cout: int, k: int, stride: int = 1) -> nn.Conv2d:
    return nn.Conv2d(cin, cout, k, stride, padding=k // 2, padding_mode="reflect", bias=False)


class BasicBlock(nn.Module):
    def __init__(self, cin: int, cout: int, stride: int):
        super().__init__()
        self.conv1, self.bn1 = _conv(cin, cout, 3, stride), _norm(cout)
        self.conv2, self.bn2 = _conv(cout, cout, 3), _norm(cout)
        self.down = None
        if stride != 1 or cin != cout:
            self.down = nn.Sequential(nn.Conv2d(cin, cout, 1, stride, bias=False), _norm(cout))

    def forward(self, x: torch.Tensor) -> torch.Tensor:  # [B, cin, H, W] -> [B, cout, H', W']
        y = F.relu(self.bn1(self.conv1(x)))
        y = self.bn2(self.conv2(y))
        return F.relu(y + (x if self.down is None else self.down(x)))


class UpConv(nn.Module):
    """x2 bilinear upsampling then 3x3 conv + norm + ELU."""

    def __init__(self, cin: int, cout: int):
        super().__init__()
        self.conv, self.norm = _conv(cin, cout, 3), _norm(cout)

    def forward(self, x: torch.Tensor, size: tuple[int, int]) -> torch.Tensor:
        x = F.interpolate(x, size=size, mode="bilinear", align_corners=False)
        return F.elu(self.norm(self.conv(x)))


class ResUNet(nn.Module):
    """images [B, 3, H, W] in 0..1 -> features [B, out_ch, ceil(H/4), ceil(W/4)]."""

    def __init__(self, widths: tuple[int, int, int] = (64, 128, 256),
                 blocks: tuple[int, int, int] = (3, 4, 6), out_ch: int = 32,
                 dec_norm: bool = False):
        super().__init__()
        w1, w2, w3 = widths
        self.stem = nn.Sequential(_conv(3, w1, 7, 2), _norm(w1), nn.ReLU(inplace=True))
        self.layer1 = self._stage(w1, w1, blocks[0])
        self.layer2 = self._stage(w1, w2, blocks[1])
        self.layer3 = self._stage(w2, w3, blocks[2])
        self.up3, self.iconv3 = UpConv(w3, w2), _conv(2 * w2, w2, 3)
        self.up2, self.iconv2 = UpConv(w2, w1), _conv(2 * w1, w1, 3)
        # new modules, not a Sequential around iconv: the weights' names stay those of the
        # encoder without them, so older files load into ``dec_norm=False`` unchanged
        self.inorm3, self.inorm2 = ((_norm(w2), _norm(w1)) if dec_norm
                                    else (nn.Identity(), nn.Identity()))
        self.out_conv = nn.Conv2d(w1, out_ch, 1)
        self.out_ch = out_ch

    @staticmethod
    def out_size(h: int, w: int) -> tuple[int, int]:
        """The (height, width) of the features of an [h, w] image: each of the stem's and
        the first stage's stride-2 convolutions (padding k // 2) rounds up."""
        return -(-h // 4), -(-w // 4)

    @staticmethod
    def _stage(cin: int, cout: int, n: int) -> nn.Sequential:
        return nn.Sequential(BasicBlock(cin, cout, 2), *[BasicBlock(cout, cout, 1)
                                                          for _ in range(n - 1)])

    def forward(self, images: torch.Tensor) -> torch.Tensor:
        x = self.stem(images * 2.0 - 1.0)  # 1/2
        x1 = self.layer1(x)  # 1/4
        x2 = self.layer2(x1)  # 1/8
        x3 = self.layer3(x2)  # 1/16
        y = self.up3(x3, x2.shape[-2:])
        y = F.elu(self.inorm3(self.iconv3(torch.cat([y, x2], 1))))
        y = self.up2(y, x1.shape[-2:])
        y = F.elu(self.inorm2(self.iconv2(torch.cat([y, x1], 1))))
        return self.out_conv(y)
