"""GN-FR training pieces: presets, scene tensors, source banks, batch sampling, one step.

Configs and presets, ``Scene`` tensors, ``SourceBank`` (a scene's views at source scale),
batch sampling, the optimizer and its learning-rate schedule, one train step. The loop
around ``train_step`` (metric lines, checkpoints, resume) is ``gnfr.fit``; all state
(model, optimizer, generator, step) is passed in here. Shapes: N scene views, Vs sources,
R rays.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass, field, replace

import torch
import torch.nn.functional as F

from gnfr.geometry import pixel_rays, sample_depths
from gnfr.losses import masked_mse, mse_denominator, mse_to_psnr
from gnfr.model import GNFR, GNFRConfig
from gnfr.renderer import SourceViews, encoder_input, forward_rays
from gnfr.view_sampler import MAX_FLARE, target_stems, train_sources


@dataclass(frozen=True)
class TrainConfig:
    """One training recipe (fine-tune or pretrain)."""

    model: GNFRConfig = GNFRConfig()
    """Architecture."""
    iters: int = 50_000
    """Optimizer steps."""
    rays: int = 256
    """Rays per step (all from one target view)."""
    samples: int = 64
    """Samples per ray, uniform in inverse depth with stratified jitter."""
    n_views: tuple[int, int] = (8, 12)
    """Range of the number N of training source views (paper: 8..12)."""
    pool_k: tuple[float, float] = (1.0, 3.0)
    """Range of k: sources are drawn from the round(k*N) nearest views."""
    random_sources: bool = False
    """GNT's draw: the N sources in a random order of the pool instead of the nearest first
    (the View Sampler's flare rule still applies)."""
    edge_rays: float = 0.0
    """Share of each step's rays drawn in proportion to the target's gradient magnitude
    (the rest uniform over its pixels); each ray's loss is weighted by the inverse of its
    pixel's drawing probability, so the objective is the same and only its noise changes
    (0: every ray uniform, as before)."""
    mirror: bool = False
    """Fine-tuning: half the steps (drawn at random) train on the scene seen in a mirror
    (``mirrored``: every view flipped left-right, its camera reflected), twice the views of
    one scene for the same number of steps. Pretraining adds mirrored scenes instead
    (``pretrain --mirror``)."""
    source_flare: float = 0.0
    """Fine-tuning: the share of steps (drawn at random) whose sources are read from a flared
    twin of the scene (``pipeline.source_flare``: one more synthetic flare, masked, on every
    view) while the target stays as photographed: the masking loss then trains points that
    every source shows on flare. Pretraining has its own share (``pretrain
    --source-flare``) and ignores this one (0: never, as before)."""
    eval_views: int = 10
    """Source views at render / evaluation time (nearest least-flared)."""
    lr_encoder: float = 5e-4
    """Adam learning rate of the encoder (GNT fine-tuning)."""
    lr_transformer: float = 2e-4
    """Adam learning rate of everything else."""
    lr_decay_steps: int = 20_000
    """Both learning rates are halved every this many steps."""
    lr_restart: float = 0.0
    """With ``lr_restart_step``: from that step on, the schedule starts again at this fraction
    of the starting rates (a warm restart of a run whose rates had decayed; 0 = none)."""
    lr_restart_step: int = 0
    """Step of the warm restart (``lr_restart``)."""
    source_scale: float = 1.0
    """Sources are encoded at this fraction of their resolution (targets stay full size)."""
    full_res_colour: bool = False
    """Sample the sources' colours (and flare masks) at their full resolution while the
    encoder still sees them at ``source_scale``: sharp colours at the features' cost."""
    encode_apart: bool = False
    """Views of different sizes (a scene padded to one size, ``Scene.extents``) encoded each
    at its own size, their feature maps padded instead of their images
    (``SourceViews.encode(apart=True)``)."""
    encoder_bf16: bool = False
    """With ``cpu_bf16``: the encoder's forward and backward in training under bf16 autocast
    too (its weights stay fp32; ``SourceViews.encode``'s ``bf16``). The render encodes in
    fp32 as before."""
    cached_features: bool = False
    """Encode every source once with a frozen encoder and reuse the features every step."""
    point_sampler: bool = True
    """GN-FR Point Sampler (off: GNT attention)."""
    flare_fallback: str = "valid"
    """What a point on flare in every source that sees it attends
    (``gnfr.transformer.FLARE_FALLBACKS``: every such view, or the darker half of them)."""
    view_sampler: bool = True
    """GN-FR View Sampler (off: nearest N sources, flared views may be targets)."""
    mask_loss: bool = True
    """GN-FR masking loss (off: MSE over every pixel)."""
    max_flare: float = MAX_FLARE
    """Views with more flare than this are never targets (with the View Sampler), unless the
    scene lists its targets (``Scene.targets``: a workspace's views.json)."""
    reference: bool = False
    """Plain fp32 path: no autocast, no fused attention (for checks and timing)."""
    cpu_bf16: bool = False
    """On the CPU: the transformers' forward and backward under bf16 autocast, as CUDA always
    trains (the encoder and the weights stay fp32). Fast only where the CPU has native bf16
    (``gnfr.renderer.native_bf16``)."""
    seed: int = 0
    """Seed of initialisation and of every random draw of the run."""
    log_every: int = 50
    """Steps between metrics.jsonl lines."""
    ckpt_every: int = 1000
    """Steps between checkpoints."""
    ckpt_seconds: float = 120.0
    """Also a checkpoint once this many seconds have passed since the last (0: by steps
    only), so that a run stopped by a time limit (a lent GPU's call, a batch scheduler)
    keeps at most this much of its work unsaved: `paper` saves every 5 000 steps, 10
    minutes of an H100. Bookkeeping, like ``log_every``: not part of what a continuation
    must match (``pipeline.finetune.continuation``)."""


PAPER = TrainConfig()
"""GN-FR fine-tuning as in the paper: GNT-sized model, 50k steps, 256 rays, 64 samples,
sources at full resolution, encoder trained end-to-end."""

PRETRAIN = replace(PAPER, iters=500_000, lr_encoder=1e-3, lr_transformer=5e-4,
                   lr_decay_steps=50_000, ckpt_every=5000)
"""Cross-scene pretraining (paper: 500k steps; GNT learning rates)."""

QUICK = replace(
    PAPER,
    model=replace(PAPER.model, enc_widths=(16, 32, 64), enc_blocks=(1, 1, 1), feat_ch=16,
                  width=32, depth=4),
    iters=3000, rays=128, samples=24, n_views=(5, 7), eval_views=6, source_scale=0.25,
    lr_encoder=1e-3, lr_transformer=5e-4, lr_decay_steps=2000, log_every=25, ckpt_every=250)
"""CPU preset (about 8-10 minutes of fine-tuning on an idle 2-core machine for an 8-10-view
scene at the default decode size). What it trades against ``PAPER`` (docs/presets.md):
4 instead of 8 view/ray block pairs of width 32 instead of 64 (about 1/10 of the
transformer's parameters), a 3-stage single-block encoder (16/32/64 channels, 16 output
features) on sources at 1/4 resolution, so fine texture comes from the target-resolution
colour samples only; 24 instead of 64 samples per ray (depth resolution), 5-7 training
and 6 rendering sources instead of 8-12 and 10 (fewer neighbours to fill a flare region
from), 128 rays and 3000 steps instead of 256 and 50k (a fit of the scene's low
frequencies, not a converged model). ``finetune --init auto`` starts it from the shipped
pretrained weights of this architecture (gnfr/weights/gnfr.md) and trains end-to-end;
``cached_features`` (frozen encoder, about a quarter faster per step) is opt-in."""

TINY = replace(QUICK, model=replace(QUICK.model, enc_widths=(8, 16, 16), feat_ch=8, width=16,
                                    depth=2),
               iters=20, rays=32, samples=8, n_views=(3, 4), eval_views=4, source_scale=0.5,
               log_every=5, ckpt_every=10)
"""Smoke-test size (seconds on CPU); useless for real scenes."""

PRESETS = {"paper": PAPER, "quick": QUICK, "pretrain": PRETRAIN,
           "pretrain-quick": replace(QUICK, iters=20_000, lr_decay_steps=10_000,
                                     n_views=(5, 8)),
           "tiny": TINY}


@dataclass
class Scene:
    """One posed scene as tensors (filled by pipeline.training_scenes)."""

    stems: list[str]
    images: torch.Tensor
    """[N, 3, H, W] uint8 target images (full resolution)."""
    K: torch.Tensor
    """[N, 3, 3] intrinsics of ``images``."""
    c2w: torch.Tensor
    """[N, 4, 4] camera-to-world (OpenCV)."""
    near: torch.Tensor
    """[N] near z-depth per view."""
    far: torch.Tensor
    """[N] far z-depth per view."""
    masks: torch.Tensor | None = None
    """[N, 1, H, W] uint8 1 = flare, or None (no masks: all clear)."""
    flare: dict[str, float] = field(default_factory=dict)
    """Flare fraction per stem."""
    ranked: dict[str, list[str]] = field(default_factory=dict)
    """Per stem, every other stem nearest first."""
    name: str = ""
    targets: list[str] | None = None
    """The views that may be training targets when the scene says so (a workspace's
    views.json flags, set by pipeline.training_scenes), else None: those within
    ``TrainConfig.max_flare``. Derived from ``flare``: reset it when ``flare`` changes."""
    extents: torch.Tensor | None = None
    """[N, 2] long: each view's own (width, height) when views of different sizes (a
    portrait photo among landscape ones) are padded to one size at the bottom and right
    (``pipeline.training_scenes.make_scene``); the padding is never a target pixel and lies
    outside its view as a source (``SourceViews.extents``), as at render time. None: every
    view fills ``images``."""

    edge_q: dict[tuple[int, float], torch.Tensor] = field(
        default_factory=dict, init=False, repr=False, compare=False)
    """Cache of :func:`edge_probabilities` by (view, share); a copy made by ``replace``
    (e.g. :func:`mirrored`) starts empty."""

    def index(self) -> dict[str, int]:
        return {s: i for i, s in enumerate(self.stems)}

    def size_of(self, i: int) -> tuple[int, int]:
        """(height, width) of view ``i`` itself, its padding excluded."""
        if self.extents is None:
            return int(self.images.shape[-2]), int(self.images.shape[-1])
        return int(self.extents[i, 1]), int(self.extents[i, 0])

    def own(self, i: int, x: torch.Tensor) -> torch.Tensor:
        """``x`` [..., H, W] (view ``i``'s image or mask, or a copy of one) cut to the view's
        own size (``size_of``): a view of ``x``, so writing into it writes into ``x``."""
        h, w = self.size_of(i)
        return x[..., :h, :w]


def mirrored(scene: Scene) -> Scene:
    """``scene`` seen in a mirror: every view (and mask) flipped left-right, and the world
    and each camera reflected in x (c2w -> S c2w S, S = diag(-1, 1, 1, 1), so the rotations
    stay proper), so a world point at pixel (x, y) of a view lands at (W - x, y) of its
    mirror (the +0.5 pixel-centre convention: cx -> W - cx). Depths, bounds and the distances
    between cameras are unchanged, so ``ranked`` and ``flare`` carry over. A padded view
    (``Scene.extents``) is flipped inside its own width, its padding staying at the right."""
    S = torch.diag(torch.tensor([-1.0, 1.0, 1.0, 1.0], dtype=scene.c2w.dtype))
    K = scene.K.clone()
    if scene.extents is None:
        K[:, 0, 2] = scene.images.shape[-1] - K[:, 0, 2]
        images = scene.images.flip(-1)
        masks = None if scene.masks is None else scene.masks.flip(-1)
    else:
        K[:, 0, 2] = scene.extents[:, 0].to(K) - K[:, 0, 2]
        images = scene.images.clone()
        masks = None if scene.masks is None else scene.masks.clone()
        for i in range(len(scene.stems)):
            w = int(scene.extents[i, 0])
            images[i, :, :, :w] = scene.images[i, :, :, :w].flip(-1)
            if masks is not None:
                masks[i, :, :, :w] = scene.masks[i, :, :, :w].flip(-1)
    return replace(scene, images=images, K=K, c2w=S @ scene.c2w @ S, masks=masks,
                   name=f"{scene.name}~mirror")


def downscale(scene: Scene, scale: float) -> tuple[torch.Tensor, torch.Tensor,
                                                   torch.Tensor | None, torch.Tensor | None]:
    """Source images [N, 3, h, w] float 0..1, K [N, 3, 3], masks [N, 1, h, w] float and
    extents [N, 2] float (None unless the scene's views are padded, ``Scene.extents``) at
    ``scale`` of the scene's resolution (area filter; K rows and extents scale exactly).
    The padding is marked as flare in the masks, as the render's source cache marks it."""
    imgs = scene.images.float() / 255.0
    masks = None if scene.masks is None else scene.masks.float()
    ext = None if scene.extents is None else scene.extents.float()
    if ext is not None:
        H, W = imgs.shape[-2:]
        pad = ~((torch.arange(W)[None, None, :] < ext[:, 0, None, None])
                & (torch.arange(H)[None, :, None] < ext[:, 1, None, None]))  # [N, H, W]
        masks = torch.zeros(len(imgs), 1, H, W) if masks is None else masks.clone()
        masks[pad[:, None]] = 1.0
    K = scene.K.clone().float()
    if scale != 1.0:
        H, W = imgs.shape[-2:]
        h, w = max(8, round(H * scale)), max(8, round(W * scale))
        imgs = F.interpolate(imgs, size=(h, w), mode="area")
        masks = None if masks is None else F.interpolate(masks, size=(h, w), mode="area")
        K[:, 0] *= w / W
        K[:, 1] *= h / H
        if ext is not None:
            ext = ext * torch.tensor([w / W, h / H])
    return imgs, K, masks, ext


@dataclass(frozen=True, eq=False)
class SourceBank:
    """Every view of a scene at source scale, on the training device: what a training
    step encodes its sources from (``SourceBank.of``; end-to-end mode encodes the batch's
    sources each step, cached-feature mode all of them once, ``prepare_sources``)."""

    images: torch.Tensor
    """[N, 3, h, w] float 0..1."""
    K: torch.Tensor
    """[N, 3, 3] intrinsics of ``images``."""
    masks: torch.Tensor | None
    """[N, 1, h, w] float 1 = flare, or None (no masks)."""
    c2w: torch.Tensor
    """[N, 4, 4] float camera-to-world."""
    feature_scale: float = 1.0
    """The encoder sees ``images`` downscaled by this (``SourceViews.encode``)."""
    enc_images: torch.Tensor | None = None
    """[N, 3, h', w'] the encoder's input when ``feature_scale`` < 1, filtered once here
    (``encoder_input``) rather than from the full-size views at every step."""
    extents: torch.Tensor | None = None
    """[N, 2] float each view's own (width, height) in ``images`` when the scene's views
    are padded (``Scene.extents``), else None."""
    apart: bool = False
    """Padded views encoded each at its own size (``TrainConfig.encode_apart``)."""
    bf16: bool = False
    """The encoder under CPU bf16 autocast (``TrainConfig.encoder_bf16``)."""

    @classmethod
    def of(cls, scene: Scene, scale: float, device, full_res_colour: bool = False,
           apart: bool = False, bf16: bool = False) -> SourceBank:
        """The views of ``scene`` at ``scale`` of their resolution (``downscale``), on
        ``device``; with ``full_res_colour`` the images stay at full resolution and only
        the encoder sees them at ``scale``; ``apart``: :attr:`apart`; ``bf16``:
        :attr:`bf16`."""
        imgs, K, masks, ext = downscale(scene, 1.0 if full_res_colour else scale)
        imgs = imgs.to(device)
        feature_scale = scale if full_res_colour else 1.0
        return cls(images=imgs, K=K.to(device),
                   masks=None if masks is None else masks.to(device),
                   c2w=scene.c2w.float().to(device), feature_scale=feature_scale,
                   enc_images=(None if feature_scale == 1.0
                               else encoder_input(imgs.float(), feature_scale)),
                   extents=None if ext is None else ext.to(device), apart=apart,
                   bf16=bf16)

    def views(self, ids: torch.Tensor, feats: torch.Tensor, device) -> SourceViews:
        """The views ``ids`` with their feature maps ``feats`` [len(ids), C, h, w] made
        elsewhere (``gnfr.ray_split``: each process encodes a share of a step's views), as
        ``encode(model, device, ids)`` would give them."""
        return self.encode(None, device, ids, feats=feats)

    def encode(self, model: GNFR | None, device, ids: torch.Tensor | None = None,
               grad: bool = False, feats: torch.Tensor | None = None) -> SourceViews:
        """The views ``ids`` (all when None) encoded by ``model`` (``SourceViews.encode``;
        ``grad`` keeps the encoder's graph; ``feats``: their features made elsewhere, the
        encoder not run: ``views``)."""
        enc, ext = self.enc_images, self.extents
        if ids is None:
            return SourceViews.encode(model, self.images, self.K, self.c2w, self.masks, device,
                                      grad=grad, feature_scale=self.feature_scale,
                                      enc_images=enc, feats=feats, extents=ext,
                                      apart=self.apart, bf16=self.bf16)
        ext = None if ext is None else ext[ids.to(ext.device)]
        if enc is not None:  # full-size colours: the views are rows of the bank, not copies
            return SourceViews.encode(model, self.images, self.K[ids], self.c2w[ids],
                                      self.masks, device, grad=grad,
                                      feature_scale=self.feature_scale, enc_images=enc[ids],
                                      rows=ids, feats=feats, extents=ext, apart=self.apart,
                                      bf16=self.bf16)
        # the encoder reads the views themselves: stack them
        return SourceViews.encode(model, self.images[ids], self.K[ids], self.c2w[ids],
                                  None if self.masks is None else self.masks[ids], device,
                                  grad=grad, feature_scale=self.feature_scale, feats=feats,
                                  extents=ext, apart=self.apart, bf16=self.bf16)


def prepare_sources(model: GNFR, scene: Scene, cfg: TrainConfig,
                    device) -> tuple[SourceBank, SourceViews | None]:
    """(bank, cache): all views at source scale on ``device``, and in cached-feature mode
    their features encoded once with the frozen encoder (which stops training)."""
    bank = SourceBank.of(scene, cfg.source_scale, device, cfg.full_res_colour,
                         cfg.encode_apart, cfg.encoder_bf16 and cfg.cpu_bf16)
    cache = None
    if cfg.cached_features:
        model.encoder.requires_grad_(False)
        cache = bank.encode(model, device)
    return bank, cache


@dataclass
class Batch:
    target: int
    """Index of the target view."""
    sources: torch.Tensor
    """[Vs] long indices of the source views."""
    rays_o: torch.Tensor
    """[R, 3]"""
    rays_d: torch.Tensor
    """[R, 3] camera-z 1."""
    t: torch.Tensor
    """[R, S] stratified sample depths."""
    rgb: torch.Tensor
    """[R, 3] target colours 0..1."""
    flare: torch.Tensor | None
    """[R] 1 where the target pixel is flare, or None."""
    weight: torch.Tensor | None = None
    """[R] each ray's loss weight (``TrainConfig.edge_rays``), or None (all equal)."""


def scene_targets(scene: Scene, cfg: TrainConfig) -> list[str]:
    """The views a step may take as its target, in scene order: with the View Sampler the
    scene's own ``targets`` when it lists them, else those within ``cfg.max_flare``
    (``view_sampler.target_stems``); every view without it (the ablation)."""
    if cfg.view_sampler and scene.targets is not None:
        keep = set(scene.targets)
        return [s for s in scene.stems if s in keep]
    flare = {s: scene.flare.get(s, 0.0) for s in scene.stems}
    return target_stems(flare, cfg.max_flare, cfg.view_sampler)


def sample_batch(scene: Scene, cfg: TrainConfig, gen: torch.Generator) -> Batch:
    """Pick a target (:func:`scene_targets`), its sources (View Sampler) and ``cfg.rays``
    random pixels of it with jittered sample depths."""
    idx = scene.index()
    flare = {s: scene.flare.get(s, 0.0) for s in scene.stems}
    targets = scene_targets(scene, cfg)
    if not targets:
        rule = ("its list of targets is empty" if cfg.view_sampler and scene.targets is not None
                else f"no view has flare <= {cfg.max_flare}")
        raise ValueError(f"scene {scene.name}: {rule}")
    tgt = targets[int(torch.randint(len(targets), (1,), generator=gen))]
    src = train_sources(scene.ranked[tgt], flare, gen, cfg.n_views, cfg.pool_k,
                        cfg.view_sampler, random_pick=cfg.random_sources)
    i = idx[tgt]
    H, W = scene.size_of(i)  # the view itself: a padded view's padding is never drawn
    weight = None
    if cfg.edge_rays > 0:
        q = edge_probabilities(scene, i, cfg.edge_rays)
        flat = torch.multinomial(q, cfg.rays, replacement=True, generator=gen)
        weight = 1.0 / (q[flat] * (H * W))
    else:
        flat = torch.randint(H * W, (cfg.rays,), generator=gen)
    ys, xs = flat // W, flat % W
    pix = torch.stack([xs, ys], 1).float() + 0.5
    o, d = pixel_rays(scene.K[i].float(), scene.c2w[i].float(), pix)
    near, far = scene.near[i].expand(cfg.rays).float(), scene.far[i].expand(cfg.rays).float()
    t = sample_depths(near, far, cfg.samples, jitter=True, generator=gen)
    rgb = scene.images[i, :, ys, xs].T.float() / 255.0
    fl = None if scene.masks is None else scene.masks[i, 0, ys, xs].float()
    return Batch(i, torch.tensor([idx[s] for s in src]), o, d, t, rgb, fl, weight)


def edge_probabilities(scene: Scene, i: int, share: float) -> torch.Tensor:
    """[H * W] drawing probabilities of view ``i``'s pixels (H, W its own size,
    ``Scene.size_of``): ``share`` in proportion to the Sobel gradient magnitude of its grey
    image, the rest uniform (cached per view)."""
    key = (i, share)
    if key not in scene.edge_q:
        grey = scene.own(i, scene.images[i]).float().mean(0, keepdim=True)[None] / 255.0
        kx = torch.tensor([[-1.0, 0, 1], [-2, 0, 2], [-1, 0, 1]])
        k = torch.stack([kx, kx.T])[:, None]  # [2, 1, 3, 3]
        g = F.conv2d(F.pad(grey, (1, 1, 1, 1), mode="replicate"), k).square().sum(1).sqrt()
        g = g.reshape(-1)
        n = g.numel()
        q = (1 - share) / n + share * (g / g.sum() if g.sum() > 0 else torch.full_like(g, 1 / n))
        scene.edge_q[key] = q / q.sum()
    return scene.edge_q[key]


def make_optimizer(model: GNFR, cfg: TrainConfig) -> torch.optim.Adam:
    """Adam with two groups: encoder and transformer (their own learning rates)."""
    return torch.optim.Adam([
        {"params": list(model.encoder.parameters()), "lr": cfg.lr_encoder, "name": "encoder"},
        {"params": model.transformer_parameters(), "lr": cfg.lr_transformer,
         "name": "transformer"}])


def set_learning_rates(opt: torch.optim.Optimizer, cfg: TrainConfig, step: int) -> float:
    """Step decay: halve every ``lr_decay_steps``, counted from ``lr_restart_step`` at
    ``lr_restart`` of the starting rates after a warm restart. Returns the factor."""
    if cfg.lr_restart > 0 and step >= cfg.lr_restart_step:
        f = cfg.lr_restart * 0.5 ** ((step - cfg.lr_restart_step) // cfg.lr_decay_steps)
    else:
        f = 0.5 ** (step // cfg.lr_decay_steps)
    for g in opt.param_groups:
        g["lr"] = (cfg.lr_encoder if g["name"] == "encoder" else cfg.lr_transformer) * f
    return f


def batch_sources(model: GNFR, batch: Batch, bank: SourceBank, cache: SourceViews | None,
                  device) -> tuple[SourceViews, torch.Tensor]:
    """The SourceViews a step reads and the ids of its sources in it: the cached views as
    they are, or the batch's sources encoded now with gradients (end-to-end)."""
    if cache is not None:
        return cache, batch.sources.to(cache.images.device)
    ids = batch.sources
    src = bank.encode(model, device, ids, grad=True)
    return src, torch.arange(len(ids), device=src.images.device)


def compute_loss(model: GNFR, batch: Batch, src: SourceViews, ids: torch.Tensor,
                 cfg: TrainConfig, whole: Batch | None = None) -> tuple[torch.Tensor, dict]:
    """The masking loss of ``batch``'s rays and what a metrics line reports of them: psnr
    (the unflared pixels), all_flared (the mean of ``forward_rays``'s) and mse (psnr's mean
    squared error). ``whole``: the step's whole batch when ``batch`` holds a part of its rays
    (``gnfr.ray_split``): the loss, mse and all_flared are then this part's share of the whole
    batch's (normalised by the whole's counts), so that the parts' add up to the whole's
    (``add_parts``); psnr is then the part's alone."""
    dev = src.images.device
    out = forward_rays(model, src, ids, batch.rays_o.to(dev), batch.rays_d.to(dev),
                       batch.t.to(dev), cfg.point_sampler, cfg.reference,
                       cpu_bf16=cfg.cpu_bf16, flare_fallback=cfg.flare_fallback)
    flare = None if batch.flare is None else batch.flare.to(dev)
    weight = None if batch.weight is None else batch.weight.to(dev)
    den_loss = den_psnr = None
    rays = len(batch.rgb)
    if whole is not None:
        rays = len(whole.rgb)
        den_psnr = mse_denominator(rays, 3, whole.flare, whole.weight).to(dev)
        den_loss = (den_psnr if cfg.mask_loss
                    else mse_denominator(rays, 3, None, whole.weight).to(dev))
    loss = masked_mse(out["rgb"], batch.rgb.to(dev), flare if cfg.mask_loss else None, weight,
                      den_loss)
    with torch.no_grad():  # weighted too: edge-drawn rays estimate the image's mean error
        psnr_mse = float(masked_mse(out["rgb"], batch.rgb.to(dev), flare, weight, den_psnr))
    return loss, {"psnr": mse_to_psnr(psnr_mse), "mse": psnr_mse,
                  "all_flared": float(out["all_flared"].sum()) / rays}


def add_parts(parts: list[dict]) -> dict:
    """One step's loss, psnr, mse and all_flared from its parts' (``compute_loss`` with
    ``whole``, a ``loss`` value added to each)."""
    mse = sum(p["mse"] for p in parts)
    return {"loss": sum(p["loss"] for p in parts), "psnr": mse_to_psnr(mse), "mse": mse,
            "all_flared": sum(p["all_flared"] for p in parts)}


def train_step(model: GNFR, opt: torch.optim.Optimizer, batch: Batch, bank: SourceBank,
               cache: SourceViews | None, cfg: TrainConfig, step: int,
               grad_hook=None, split=None) -> dict:
    """One optimizer step at the learning rates of ``step`` (``set_learning_rates``).
    ``bank``: all views at source scale; ``cache`` the pre-encoded views in cached-feature
    mode (``prepare_sources`` makes both).
    ``grad_hook`` (e.g. a DDP all-reduce) runs between backward and the update.
    ``split`` (a started ``gnfr.ray_split.RaySplit`` of this model and ``cfg``): other
    processes take a share of the batch's rays and its views' encoding, and their gradients
    are added to this one's before the update.
    Returns loss, psnr (non-flare pixels of the target), all_flared, lr factor."""
    model.train()
    lr_f = set_learning_rates(opt, cfg, step)
    opt.zero_grad(set_to_none=True)
    device = next(model.parameters()).device
    if split is not None:
        info = split.step(model, batch, bank, cache)
    else:
        ctx = torch.no_grad() if cache is not None else contextlib.nullcontext()
        with ctx:  # the encoder's graph is only needed end-to-end
            src, ids = batch_sources(model, batch, bank, cache, device)
        loss, info = compute_loss(model, batch, src, ids, cfg)
        loss.backward()
        info = {"loss": float(loss.detach()), **info}
    if grad_hook is not None:
        grad_hook(model)
    opt.step()
    return {k: info[k] for k in ("loss", "psnr", "all_flared")} | {"lr_factor": lr_f}
