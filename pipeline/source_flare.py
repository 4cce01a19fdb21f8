"""Synthetic flare on a fine-tune's sources only: a supervision for what no source sees clean.

GN-FR's masking loss never trains a pixel a target shows as flare, and its Point Sampler
never lets a point attend a flared source while one clean source sees it. So a point that is
on flare in every source (the light at the same place in every photo) is never supervised:
the network falls back to attending the flared views and draws their glow (lund's fill,
docs/history/gnfr.md, "Sixty-seventh session").

A *flared twin* of the scene supplies that supervision: the same views with one more flare
drawn on them the way ``deflare-scene synth`` draws it (one lens, one point light placed in
the world and projected into every view, ``pipeline.synth.view_flare``), its exact mask added
to each view's own. A step that reads a twin takes its target from the scene itself (clean
where the twin is flared; its own flare still masked out of the loss) and its sources from
the twin, so where the twin's flare covers every source the target's true colour is what the
network must draw. The light's core is left out of the twin (the target does not show it).

Twins are drawn once from the run's seed (a resumed run draws the same), and a step reads
one with probability ``TrainConfig.source_flare``.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import torch

from gnfr.train import Scene
from pipeline.cameras import Cameras, Frame

TWINS = 4
"""Flared twins a fine-tune with ``source_flare`` draws (each its own lens and light)."""


def scene_cameras(scene: Scene) -> Cameras:
    """The views of ``scene`` as pipeline cameras (its K, c2w, bounds and each view's own
    image size, ``Scene.size_of``)."""
    sizes = [scene.size_of(i) for i in range(len(scene.stems))]
    frames = [Frame(name=s, stem=s, K=scene.K[i].numpy(), width=w, height=h,
                    c2w=scene.c2w[i].numpy(), near=float(scene.near[i]),
                    far=float(scene.far[i]))
              for i, (s, (h, w)) in enumerate(zip(scene.stems, sizes, strict=True))]
    return Cameras(frames)


def twin_seed(seed: int, index: int) -> int:
    """The synth seed of a run's ``index``-th twin (distinct from the run's other draws)."""
    return 1000 * (seed + 1) + index


def flared_twin(scene: Scene, seed: int, kinds: tuple[str, ...] | None = None) -> Scene:
    """``scene`` with one more flare drawn on every view by ``synth``'s rule (seed ``seed``;
    ``kinds`` of flare, default all), its mask added to each view's; the core left out."""
    from pipeline.colour import srgb_to_linear
    from pipeline.flare import (
        FlareConfig,
        FlareLayers,
        apply_flare,
        psf_bank,
        sample_intensity,
        sample_lens,
    )
    from pipeline.synth import SynthConfig, choose_light, view_flare

    flare = FlareConfig() if kinds is None else FlareConfig(kinds=tuple(kinds))
    cfg = SynthConfig(out=Path("."), seed=seed, flare=flare)
    cams = scene_cameras(scene)
    rng = np.random.default_rng([seed, 0])  # synth's order: lens, light, intensity
    lens = sample_lens(flare, rng)
    light = choose_light(cams, rng)
    base = sample_intensity(flare, rng)
    if "scatter" in lens.kinds:
        psf_bank(flare)
    images = scene.images.clone()
    masks = (torch.zeros_like(scene.images[:, :1]) if scene.masks is None
             else scene.masks.clone())
    for i, frame in enumerate(cams.frames):  # each view at its own size (padding left out)
        img = scene.own(i, scene.images[i]).permute(1, 2, 0).numpy()
        layers, _ = view_flare(cfg, lens, frame, light, base, i, srgb_to_linear(img / 255.0))
        if not layers.flare.any():
            continue
        no_core = FlareLayers(layers.flare, np.zeros_like(layers.core), layers.mask)
        out = np.round(apply_flare(img, no_core) * 255).astype(np.uint8)
        scene.own(i, images[i])[:] = torch.from_numpy(out).permute(2, 0, 1)
        scene.own(i, masks[i, 0])[:] |= torch.from_numpy(layers.mask.astype(np.uint8))
    return replace(scene, images=images, masks=masks, name=f"{scene.name}~flare{seed}")


def flared_twins(scene: Scene, seed: int, n: int = TWINS,
                 kinds: tuple[str, ...] | None = None) -> list[Scene]:
    """The ``n`` flared twins of a run with seed ``seed`` (:func:`flared_twin`)."""
    return [flared_twin(scene, twin_seed(seed, j), kinds) for j in range(n)]
