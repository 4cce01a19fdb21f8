"""The GN-FR model: ResUNet encoder + alternating view/ray transformers + colour head (GNT).

Shapes: R rays, S samples per ray, V source views, C = ``feat_ch``, D = ``width``.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass

import torch
import torch.nn as nn

from gnfr.encoder import ResUNet
from gnfr.transformer import RayTransformer, ViewTransformer, masked_max


@dataclass(frozen=True)
class GNFRConfig:
    """Architecture of a GN-FR model (stored in every checkpoint's metadata)."""

    enc_widths: tuple[int, int, int] = (64, 128, 256)
    """Channels of the encoder's three ResNet stages."""
    enc_blocks: tuple[int, int, int] = (3, 4, 6)
    """BasicBlocks per encoder stage (ResNet-34 layout in GNT)."""
    feat_ch: int = 32
    """Feature channels the encoder outputs, at 1/4 of the source resolution."""
    width: int = 64
    """Transformer width D."""
    depth: int = 8
    """Number of view/ray transformer block pairs."""
    heads: int = 4
    """Heads of the ray transformer's self-attention."""
    ff_mult: int = 4
    """Feed-forward hidden width as a multiple of D."""
    n_freqs_pts: int = 10
    """NeRF sin/cos frequencies of the sample position."""
    n_freqs_dirs: int = 10
    """NeRF sin/cos frequencies of the ray direction."""
    dropout: float = 0.0
    """Dropout in attention outputs and feed-forward layers (training only)."""
    dec_norm: bool = False
    """InstanceNorm after the encoder decoder's skip-merging convolutions, as in GNT
    (``ResUNet``). A file without this key was trained without it."""
    flare_flag: bool = False
    """Each source's sampled colour and features carry one more input, 1 where the point is
    on flare in that source (the Point Sampler's mask): a point on flare in every source,
    which falls back to attending them, is then known to the network as such (not in
    GNT or GN-FR; ``finetune --flare-flag``). Weights without it load into a model with it
    as the same function (``grown_from``: the flag's input weights start at zero). A file
    without this key was trained without it."""

    def architecture(self) -> GNFRConfig:
        """This config with what holds no weights (``dropout``) at its default: two configs
        with equal architectures load each other's weights."""
        return dataclasses.replace(self, dropout=0.0)

    def grown_from(self, other: GNFRConfig) -> bool:
        """Whether weights of architecture ``other`` load into this one: the same
        architecture, or the same but for the flare flag, which ``other`` lacks."""
        a, b = self.architecture(), other.architecture()
        return a == b or (a.flare_flag and not b.flare_flag
                          and a == dataclasses.replace(b, flare_flag=True))

    def to_json(self) -> str:
        return json.dumps(dataclasses.asdict(self), sort_keys=True)

    @classmethod
    def from_json(cls, text: str) -> GNFRConfig:
        d = json.loads(text)
        names = {f.name for f in dataclasses.fields(cls)}
        d = {k: tuple(v) if isinstance(v, list) else v for k, v in d.items() if k in names}
        return cls(**d)


def positional_encoding(x: torch.Tensor, n_freqs: int) -> torch.Tensor:
    """NeRF encoding: x [..., 3] -> [..., 3 + 6 * n_freqs] (x, sin(2^k x), cos(2^k x))."""
    freqs = 2.0 ** torch.arange(n_freqs, device=x.device, dtype=x.dtype)
    xf = (x[..., None, :] * freqs[:, None]).flatten(-2)
    return torch.cat([x, torch.sin(xf), torch.cos(xf)], -1)


class GNFR(nn.Module):
    def __init__(self, config: GNFRConfig = GNFRConfig()):
        super().__init__()
        c = self.config = config
        D = c.width
        self.encoder = ResUNet(c.enc_widths, c.enc_blocks, c.feat_ch, c.dec_norm)
        self.rgbfeat_fc = nn.Sequential(nn.Linear(c.feat_ch + 3 + int(c.flare_flag), D),
                                        nn.ReLU(), nn.Linear(D, D))
        emb = 6 + 6 * (c.n_freqs_pts + c.n_freqs_dirs)
        self.view_blocks = nn.ModuleList(
            [ViewTransformer(D, c.ff_mult, c.dropout) for _ in range(c.depth)])
        self.ray_blocks = nn.ModuleList(
            [RayTransformer(D, c.heads, c.ff_mult, c.dropout) for _ in range(c.depth)])
        self.q_fcs = nn.ModuleList(
            [nn.Sequential(nn.Linear(D + emb, D), nn.ReLU(), nn.Linear(D, D))
             if i % 2 == 0 else nn.Identity() for i in range(c.depth)])
        self.norm = nn.LayerNorm(D)
        self.rgb_fc = nn.Linear(D, 3)

    def grown_state(self, state: dict[str, torch.Tensor]) -> dict[str, torch.Tensor]:
        """The weights of a model without the flare flag made to load into this one, which
        has it (``GNFRConfig.grown_from``): the flag's input column of the first colour and
        feature layer added at zero, so the model computes what the weights did."""
        key = "rgbfeat_fc.0.weight"
        w = state[key]
        if self.config.flare_flag and w.shape[1] == self.rgbfeat_fc[0].in_features - 1:
            state = {**state, key: torch.cat([w, w.new_zeros(w.shape[0], 1)], 1)}
        return state

    def encode(self, images: torch.Tensor) -> torch.Tensor:
        """images [V, 3, H, W] in 0..1 -> features [V, C, ceil(H/4), ceil(W/4)]."""
        return self.encoder(images)

    def transformer_parameters(self) -> list[nn.Parameter]:
        return [p for n, p in self.named_parameters() if not n.startswith("encoder.")]

    def forward(self, points: torch.Tensor, viewdirs: torch.Tensor, rgb_feat: torch.Tensor,
                rel_dir: torch.Tensor, attend: torch.Tensor, t: torch.Tensor,
                fused: bool = True, with_depth: bool = True, flared: torch.Tensor | None = None
                ) -> tuple[torch.Tensor, torch.Tensor | None]:
        """Colour and depth of each ray.

        points: [R, S, 3]; viewdirs: [R, 3] unit; rgb_feat: [R, S, V, 3 + C] sampled colour
        and features; rel_dir: [R, S, V, 4]; attend: [R, S, V] bool (Point Sampler mask,
        at least one True per point, see ``gnfr.transformer.attention_mask``);
        t: [R, S] sample depths; flared: [R, S, V] bool, where each point is on flare in
        each view (read with ``flare_flag``; None: nowhere). ``fused=False`` uses the plain
        reference attention.
        Returns rgb [R, 3] and depth [R] (last ray-attention weights times t), or None
        without ``with_depth`` (then the last ray block may use fused attention too).
        """
        R, S = points.shape[:2]
        pe_dirs = positional_encoding(viewdirs, self.config.n_freqs_dirs)  # once per ray
        embed = torch.cat([positional_encoding(points, self.config.n_freqs_pts),
                           pe_dirs[:, None].expand(R, S, -1)], -1)
        if self.config.flare_flag:
            flag = (torch.zeros_like(rgb_feat[..., :1]) if flared is None
                    else flared[..., None].to(rgb_feat.dtype))
            rgb_feat = torch.cat([rgb_feat, flag], -1)
        feats = self.rgbfeat_fc(rgb_feat)  # [R, S, V, D]
        q = masked_max(feats, attend)  # [R, S, D]
        weights = None
        last = len(self.view_blocks) - 1
        blocks = zip(self.view_blocks, self.ray_blocks, self.q_fcs, strict=True)
        for i, (vb, rb, qf) in enumerate(blocks):
            q = vb(q, feats, rel_dir, attend, fused=fused)
            if i % 2 == 0:
                q = qf(torch.cat([q, embed.to(q.dtype)], -1))
            q, weights = rb(q, fused=fused, return_weights=(i == last and with_depth))
        rgb = self.rgb_fc(self.norm(q).mean(dim=1))
        if weights is None:
            return rgb.float(), None
        return rgb.float(), (weights * t).sum(-1).float()
