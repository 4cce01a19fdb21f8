"""Renderer core: encode source views once, then render any rays against the cache.

```python
src = SourceViews.encode(model, images, K, c2w, masks, device)    # once per scene
out = render_rays(model, src, src_ids, rays_o, rays_d, near, far, n_samples=64)
```
Rendering is deterministic (bin-centre samples, eval mode) and uses bf16 autocast on CUDA.
Shapes: V cached views, Vs views used for a batch of rays, R rays, S samples per ray.
"""

from __future__ import annotations

import contextlib
import os
from dataclasses import dataclass

import torch
import torch.nn.functional as F

from gnfr.checkpoint import load_model  # noqa: F401  (part of the renderer API)
from gnfr.encoder import ResUNet
from gnfr.geometry import (
    inside_image,
    project,
    relative_directions,
    sample_bilinear,
    sample_depths,
)
from gnfr.model import GNFR
from gnfr.transformer import attention_mask


def native_bf16() -> bool:
    """Whether this CPU computes bf16 natively (AVX512-BF16 or AMX, as oneDNN sees it):
    without it bf16 is emulated, about ten times slower than fp32."""
    try:
        return bool(torch.ops.mkldnn._is_mkldnn_bf16_supported())
    except (AttributeError, RuntimeError):
        return False


AUTO_BF16 = True
"""Whether the render's and the fine-tune's ``bf16`` left unset turns CPU bf16 on where the CPU
has it natively (``native_bf16``). On since the forty-eighth session's rule passed on the
development scenes (the de-flared photos' flare region -0.025 dB, novel views -0.032 dB,
within the rule's seed spread; the fine-tune about 1.3x and the frames 1.39x faster on this
EPYC; docs/performance.md, "bf16 on the CPU")."""


BF16_ENV = "DEFLARE_CPU_BF16"
"""Environment variable: ``0`` keeps every stage's default in fp32 on any CPU (explicit
``--bf16`` still wins): for runs that must repeat across machines, and the test suite."""


def cpu_bf16(choice: bool | None, device: torch.device | str) -> bool:
    """Whether a stage on ``device`` runs GN-FR under CPU bf16 autocast: never on CUDA (which
    always autocasts its own way), ``choice`` when given, else ``AUTO_BF16`` where the CPU
    has native bf16 and ``DEFLARE_CPU_BF16`` is not ``0``."""
    if torch.device(device).type != "cpu":
        return False
    if choice is not None:
        return bool(choice)
    return AUTO_BF16 and os.environ.get(BF16_ENV, "").strip() != "0" and native_bf16()


def emulated_bf16(stage: str, on: bool) -> str | None:
    """The one line a stage warns with when it runs CPU bf16 (``on``, as ``cpu_bf16``
    resolved it) on a CPU without native bf16; None otherwise."""
    if on and not native_bf16():
        return (f"{stage}: this CPU has no native bf16: --bf16 is emulated, several times "
                "slower than fp32 (drop --bf16)")
    return None


def autocast(device: torch.device | str, enabled: bool = True, cpu: bool = False):
    """bf16 autocast on CUDA, and on the CPU with ``cpu`` (the render's ``--bf16``); a no-op
    elsewhere."""
    device = torch.device(device)
    if enabled and (device.type == "cuda" or (cpu and device.type == "cpu")):
        return torch.autocast(device.type, dtype=torch.bfloat16)
    return contextlib.nullcontext()


@dataclass
class SourceViews:
    """Source views with their encoded feature maps (each view encoded once)."""

    images: torch.Tensor
    """[V, 3, H, W] float colours in 0..1 (sampled at this size; features may be coarser)."""
    feats: torch.Tensor
    """[V, C, h, w] encoder features (h, w about H/4, W/4, times ``feature_scale``)."""
    K: torch.Tensor
    """[V, 3, 3] intrinsics of ``images`` (continuous-pixel convention, gnfr.geometry)."""
    c2w: torch.Tensor
    """[V, 4, 4] camera-to-world (OpenCV)."""
    masks: torch.Tensor | None
    """[V, 1, H, W] float, 1 = flare; None when no masks are known (Point Sampler off)."""
    rows: torch.Tensor | None = None
    """[V] long: the row of ``images`` and ``masks`` that holds each view, when they are a
    larger bank shared without copying (``SourceBank.encode``); None: view v is row v."""
    extents: torch.Tensor | None = None
    """[V, 2] float: each view's own (width, height) in pixels of ``images``, when views of
    different sizes are padded to one (``pipeline.render.sources.encode_sources``): a point
    in a view's padding is outside that view. None: every view fills the whole size."""
    feat_scale: torch.Tensor | None = None
    """[V, 2] float: feature pixels per pixel of ``images`` (x, y) of each view, when views
    of different sizes were encoded each at its own size and their feature maps padded
    (``encode(apart=True)``): a view's features fill only its own corner of ``feats``.
    None: every feature map covers the whole of ``images``."""

    @property
    def w2c(self) -> torch.Tensor:  # [V, 4, 4]
        return torch.linalg.inv(self.c2w)

    @property
    def size(self) -> tuple[int, int]:
        return int(self.images.shape[-2]), int(self.images.shape[-1])

    @classmethod
    def encode(cls, model: GNFR, images: torch.Tensor, K: torch.Tensor, c2w: torch.Tensor,
               masks: torch.Tensor | None, device, chunk: int = 4,
               grad: bool = False, feature_scale: float = 1.0,
               enc_images: torch.Tensor | None = None,
               rows: torch.Tensor | None = None,
               feats: torch.Tensor | None = None,
               extents: torch.Tensor | None = None, apart: bool = False,
               bf16: bool = False) -> SourceViews:
        """Encode views in chunks of ``chunk``. images [V, 3, H, W] 0..1; K [V, 3, 3] of
        ``images``; c2w [V, 4, 4]; masks [V, 1, H, W] 0/1 or None. ``grad=True`` keeps the
        graph (end-to-end training); otherwise no gradients and bf16 autocast on CUDA.
        ``feature_scale`` < 1 runs the encoder on the images downscaled by it (area filter)
        while colours and masks are still sampled from ``images`` at their full size: the
        feature maps cover the same field of view, so one projection serves both.
        ``enc_images``: the encoder's input already made (:func:`encoder_input` of
        ``images``), for a caller that encodes the same views at every step. ``rows``: the
        views are these rows of ``images`` and ``masks`` (a bank kept whole, not copied;
        ``enc_images``, ``K`` and ``c2w`` are then the views' own). ``feats``: the views'
        feature maps made elsewhere (``gnfr.ray_split``): the encoder does not run.
        ``extents``: [V, 2] each view's own (width, height) in ``images`` when padded
        (:attr:`extents`). ``apart`` (with ``extents``): each view encoded at its own size,
        padding cut off, and its feature map padded with zeros to the padded size's
        (:attr:`feat_scale`): its features are then those of the view encoded alone,
        which the padding's black no longer reaches through the encoder's instance norms
        and convolutions, and the encoder reads no padding (exact where each view's size
        times ``feature_scale`` is whole). ``bf16``: on the CPU, the encoder runs under bf16
        autocast, with ``grad`` too (``TrainConfig.encoder_bf16``)."""
        device = torch.device(device)
        images = images.to(device, torch.float32)
        if rows is not None and enc_images is None:
            raise ValueError("SourceViews.encode: rows need the views' enc_images")
        n = images.shape[0] if rows is None else len(rows)
        layout = None
        if apart and extents is not None:
            enc_hw = (tuple(enc_images.shape[-2:]) if enc_images is not None
                      else encoder_size(*images.shape[-2:], feature_scale))
            layout = apart_layout(extents, tuple(images.shape[-2:]), enc_hw)
        if feats is None:
            parts = []
            ctx = contextlib.nullcontext() if grad else torch.no_grad()
            with ctx, autocast(device, enabled=not grad or bf16, cpu=bf16):
                for i in range(0, n, chunk):
                    x = (encoder_input(images[i:i + chunk], feature_scale)
                         if enc_images is None
                         else enc_images[i:i + chunk].to(device, torch.float32))
                    parts.append(model.encode(x).float() if layout is None else
                                 _encode_apart(model, x, layout.crops[i:i + chunk],
                                               layout.out_hw))
            feats = torch.cat(parts)
        return cls(images=images, feats=feats, K=K.to(device, torch.float32),
                   c2w=c2w.to(device, torch.float32),
                   masks=None if masks is None else masks.to(device, torch.float32),
                   rows=None if rows is None else rows.to(device),
                   extents=None if extents is None else extents.to(device, torch.float32),
                   feat_scale=None if layout is None else layout.feat_scale.to(device))

    def inside(self, src_ids: torch.Tensor, xy: torch.Tensor,
               depth: torch.Tensor) -> torch.Tensor:
        """[Vs, P] bool: the projections ``xy`` [Vs, P, 2] (depths ``depth`` [Vs, P]) of
        points into the views ``src_ids`` lie in front of each camera and inside its image,
        its padding excluded (:attr:`extents`)."""
        ok = inside_image(xy, depth, self.size)
        if self.extents is None:
            return ok
        ext = self.extents[src_ids.to(self.extents.device)]
        return ok & (xy[..., 0] <= ext[:, None, 0]) & (xy[..., 1] <= ext[:, None, 1])


def encoder_size(H: int, W: int, feature_scale: float) -> tuple[int, int]:
    """The (height, width) the encoder sees an [H, W] image at (:func:`encoder_input`)."""
    if feature_scale == 1.0:
        return H, W
    return max(8, round(H * feature_scale)), max(8, round(W * feature_scale))


def encoder_input(images: torch.Tensor, feature_scale: float) -> torch.Tensor:
    """[V, 3, H, W] images as the encoder sees them: area-filtered down by ``feature_scale``
    (at least 8 pixels a side), unchanged at 1."""
    if feature_scale == 1.0:
        return images
    return F.interpolate(images, size=encoder_size(*images.shape[-2:], feature_scale),
                         mode="area")


@dataclass
class ApartLayout:
    """How views of different sizes padded to one are encoded each at its own size
    (``SourceViews.encode(apart=True)``)."""

    crops: list[tuple[int, int]]
    """Each view's own (height, width) in the encoder's input (its padding cut off)."""
    out_hw: tuple[int, int]
    """The feature maps' padded (height, width): the features of the whole padded size."""
    feat_scale: torch.Tensor
    """[V, 2] float feature pixels per image pixel (x, y) of each view."""


def apart_layout(extents: torch.Tensor, image_hw: tuple[int, int],
                 enc_hw: tuple[int, int]) -> ApartLayout:
    """The layout of views whose own (width, height) in images of ``image_hw`` are
    ``extents`` [V, 2], the encoder seeing those images at ``enc_hw``."""
    (H, W), (eh, ew) = image_hw, enc_hw
    crops, scale = [], []
    for w, h in extents.tolist():
        ch, cw = min(eh, max(1, round(h * eh / H))), min(ew, max(1, round(w * ew / W)))
        fh, fw = ResUNet.out_size(ch, cw)
        crops.append((ch, cw))
        scale.append((fw / w, fh / h))
    return ApartLayout(crops, ResUNet.out_size(eh, ew), torch.tensor(scale))


def _encode_apart(model: GNFR, x: torch.Tensor, crops: list[tuple[int, int]],
                  out_hw: tuple[int, int]) -> torch.Tensor:
    """Features [V, C, *out_hw] of the encoder inputs ``x`` [V, 3, h, w], each cut to its
    own size ``crops[v]`` (views of one size encoded together) and zero-padded."""
    out: list[torch.Tensor | None] = [None] * len(crops)
    for ch, cw in dict.fromkeys(crops):
        idx = [v for v, c in enumerate(crops) if c == (ch, cw)]
        f = model.encode(x[idx, :, :ch, :cw]).float()
        f = F.pad(f, (0, out_hw[1] - f.shape[-1], 0, out_hw[0] - f.shape[-2]))
        for k, v in enumerate(idx):
            out[v] = f[k]
    return torch.stack(out)


def gather(src: SourceViews, src_ids: torch.Tensor, points: torch.Tensor,
           w2c: torch.Tensor | None = None):
    """Project points into the chosen source views and sample colour, features and flare.

    src_ids: [Vs] long; points: [R, S, 3]; w2c: optional precomputed [V, 4, 4].
    Returns rgb_feat [R, S, Vs, 3 + C], valid [R, S, Vs] bool and flared [R, S, Vs] bool
    (None without masks): on flare = mask sampled bilinearly at the projection > 0.5.
    """
    R, S, _ = points.shape
    w2c = src.w2c if w2c is None else w2c
    xy, depth = project(points.reshape(-1, 3), src.K[src_ids], w2c[src_ids])  # [Vs, P, 2]
    size = src.size
    rows = src_ids if src.rows is None else src.rows[src_ids]
    rgb = sample_rows(src.images, rows, xy, size)
    if src.feat_scale is None:
        feat = sample_bilinear(src.feats[src_ids], xy, size)
    else:  # each view's features fill only its own corner of the padded maps
        feat = sample_bilinear(src.feats[src_ids], xy * src.feat_scale[src_ids][:, None],
                               tuple(src.feats.shape[-2:]))

    def to_rsv(x: torch.Tensor) -> torch.Tensor:  # [Vs, P, ...] -> [R, S, Vs, ...]
        return x.reshape(x.shape[0], R, S, *x.shape[2:]).movedim(0, 2)

    # contiguous: a permuted view would make every linear layer downstream copy its input
    rgb_feat = to_rsv(torch.cat([rgb, feat.to(rgb.dtype)], -1)).contiguous()
    valid = to_rsv(src.inside(src_ids, xy, depth))
    flared = None
    if src.masks is not None:
        flared = to_rsv(sample_rows(src.masks, rows, xy, size)[..., 0] > 0.5)
    return rgb_feat, valid, flared


def sample_rows(maps: torch.Tensor, rows: torch.Tensor, xy: torch.Tensor,
                size_hw: tuple[int, int]) -> torch.Tensor:
    """``sample_bilinear(maps[rows], xy, size_hw)`` without stacking the chosen maps: on the
    CPU each view is sampled from its own row (a full-size image bank is not copied at every
    step; the values are the same), elsewhere the chosen rows are stacked."""
    if maps.device.type != "cpu":
        return sample_bilinear(maps[rows], xy, size_hw)
    return torch.cat([sample_bilinear(maps[r:r + 1], xy[j:j + 1], size_hw)
                      for j, r in enumerate(rows.tolist())])


def forward_rays(model: GNFR, src: SourceViews, src_ids: torch.Tensor, rays_o: torch.Tensor,
                 rays_d: torch.Tensor, t: torch.Tensor, point_sampler: bool = True,
                 reference: bool = False, w2c: torch.Tensor | None = None,
                 with_depth: bool = True, cpu_bf16: bool = False,
                 flare_fallback: str = "valid") -> dict:
    """One differentiable pass for rays at given depths (training and rendering share it).

    rays_o, rays_d: [R, 3]; t: [R, S] z-depths; src_ids: [Vs]. ``reference=True`` is the
    plain fp32 path (no autocast, no fused attention); ``cpu_bf16`` runs the model under bf16
    autocast on the CPU too (CUDA always does); ``flare_fallback``: what a point on flare in
    every view attends (``gnfr.transformer.FLARE_FALLBACKS``). Returns rgb [R, 3], depth [R]
    (None without ``with_depth``: the explicit attention it needs is then skipped) and
    all_flared [R] (fraction of the ray's samples that were on flare in every source view
    they were valid in and so fell back to ``flare_fallback``'s views).
    """
    points = rays_o[:, None] + t[..., None] * rays_d[:, None]  # [R, S, 3]
    rgb_feat, valid, flared = gather(src, src_ids, points, w2c)
    attend, all_flared = attention_mask(valid, flared if point_sampler else None,
                                        rgb_feat[..., :3], flare_fallback)
    rel_dir = relative_directions(points, rays_o, src.c2w[src_ids, :3, 3])
    with autocast(rays_o.device, enabled=not reference, cpu=cpu_bf16):
        rgb, depth = model(points, F.normalize(rays_d, dim=-1), rgb_feat, rel_dir, attend, t,
                           fused=not reference, with_depth=with_depth, flared=flared)
    return {"rgb": rgb, "depth": depth, "all_flared": all_flared.float().mean(-1)}


def seen_share(src: SourceViews, src_ids: torch.Tensor, rays_o: torch.Tensor,
               rays_d: torch.Tensor, near: torch.Tensor, far: torch.Tensor, n_samples: int,
               chunk: int = 8192) -> torch.Tensor:
    """[R] float: the share of each ray's samples (``render_rays``' depths between ``near``
    and ``far``) that lie in front of and inside at least one of the sources ``src_ids``
    (``gather``'s ``valid``). 0: no source sees any of the ray, and GN-FR draws it from
    zero colours and features."""
    out = []
    device = src.K.device
    ids = src_ids.to(device)
    K, w2c = src.K[ids], src.w2c[ids]
    with torch.inference_mode():
        for i in range(0, rays_o.shape[0], chunk):
            o = rays_o[i:i + chunk].to(device, torch.float32)
            d = rays_d[i:i + chunk].to(device, torch.float32)
            t = sample_depths(near[i:i + chunk].to(o), far[i:i + chunk].to(o), n_samples,
                              jitter=False)
            points = o[:, None] + t[..., None] * d[:, None]  # [r, S, 3]
            xy, depth = project(points.reshape(-1, 3), K, w2c)
            valid = src.inside(ids, xy, depth).any(0)  # [r * S]
            out.append(valid.reshape(t.shape).float().mean(-1).cpu())
    return torch.cat(out) if out else torch.zeros(0)


def render_rays(model: GNFR, src: SourceViews, src_ids: torch.Tensor, rays_o: torch.Tensor,
                rays_d: torch.Tensor, near: torch.Tensor, far: torch.Tensor, n_samples: int,
                chunk: int = 1024, point_sampler: bool = True, progress=None,
                with_depth: bool = True, pad: bool = False, cpu_bf16: bool = False,
                flare_fallback: str = "valid") -> dict:
    """Render rays deterministically in chunks (``cpu_bf16``, ``flare_fallback``: see
    ``forward_rays``).

    src_ids: [Vs] long (which cached views to use); rays_o, rays_d: [R, 3] (``rays_d`` with
    camera-z 1, see gnfr.geometry.pixel_rays); near, far: [R] z-depths. ``progress``: an
    optional callable given the number of rays finished after each chunk.
    Returns rgb [R, 3] (clamped to 0..1), depth [R] (only ``with_depth``), all_flared [R]
    (see forward_rays).
    ``pad``: the last, shorter chunk is padded to ``chunk`` rays (its last ray repeated,
    the extra outputs dropped), so every forward pass has one shape: a model compiled
    with ``torch.compile(dynamic=False)`` then compiles once, not once per frame.
    Runs under ``torch.inference_mode``; the returned tensors are ordinary tensors.
    """
    was_training = model.training
    model.eval()
    device = src.images.device
    src_ids = src_ids.to(device)
    w2c = src.w2c
    outs = {"rgb": [], "all_flared": [], **({"depth": []} if with_depth else {})}
    try:
        with torch.inference_mode():
            for i in range(0, rays_o.shape[0], chunk):
                sl = slice(i, i + chunk)
                o, d = rays_o[sl].to(device, torch.float32), rays_d[sl].to(device, torch.float32)
                lo, hi = near[sl].to(o), far[sl].to(o)
                n = o.shape[0]
                if pad and n < chunk:
                    o, d, lo, hi = (torch.cat([x, x[-1:].expand(chunk - n, *x.shape[1:])])
                                    for x in (o, d, lo, hi))
                t = sample_depths(lo, hi, n_samples, jitter=False)
                out = forward_rays(model, src, src_ids, o, d, t, point_sampler, w2c=w2c,
                                   with_depth=with_depth, cpu_bf16=cpu_bf16,
                                   flare_fallback=flare_fallback)
                for k in outs:  # kept on the device: one copy to the host at the end
                    outs[k].append(out[k][:n].float())
                if progress is not None:
                    progress(min(i + chunk, rays_o.shape[0]))
    finally:
        model.train(was_training)
    res = {k: torch.cat(v).cpu().clone() for k, v in outs.items()}  # outside: normal tensors
    res["rgb"] = res["rgb"].clamp(0, 1)
    return res
