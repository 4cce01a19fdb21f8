"""A lens: drawn once per scene, so that rendering it from any view is cheap and consistent.

Drawn from a :class:`~pipeline.flare.config.FlareConfig`: its ``scatter`` lens and light
first, then which kinds it has and each kind's parameters."""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field

import numpy as np

from pipeline.flare.common import _loguniform, _uniform, blackbody_rgb, hsv_rgb
from pipeline.flare.config import FlareConfig
from pipeline.flare.ghosts import Ghost, sample_ghost_chain
from pipeline.flare.glare import sample_veiling_glare
from pipeline.flare.starburst import sample_starburst
from pipeline.flare.streaks import sample_streaks


@dataclass
class Lens:
    """One lens: a PSF of the bank and its placement, ghosts, glare, core and light colour.
    Sampled once per scene (:func:`sample_lens`); rendering it at any light position is
    cheap and consistent across views."""

    cfg: FlareConfig = field(repr=False)
    """The config the lens was drawn from (gives its PSF bank and mask thresholds)."""
    psf_index: int
    """Which PSF of the bank."""
    blades: int
    """Aperture shape for the ghosts: 0 = circle, n = n-gon."""
    blade_rotation: float
    """Rotation of the polygonal ghosts (radians)."""
    psf_rotation: float
    """Rotation of the scatter PSF on the image (radians)."""
    psf_extent: float
    """PSF grid side on the image, fraction of the diagonal."""
    scatter_flux: float
    """Flux of the scatter layer at intensity 1."""
    ghosts: list[Ghost]
    glare_amplitude: float
    glare_width: float
    glare_tint: np.ndarray
    """[3] linear RGB tint of the glare (max 1)."""
    light_rgb: np.ndarray
    """[3] linear RGB colour of the light (max 1)."""
    core_radius: float
    core_level: float
    kinds: tuple[str, ...] = ("scatter",)
    """The kinds of flare this lens renders, in this order (drawn from ``cfg.kinds``); the
    fields above are the ``scatter`` kind's (and the light's, which all kinds share)."""
    kind_params: dict[str, object] = field(default_factory=dict)
    """Parameters of its other kinds, by kind: :class:`Starburst` (``starburst``),
    :class:`GhostChain` (``ghosts``), :class:`Streaks` (``streaks``), :class:`VeilingGlare`
    (``glare``)."""

    def summary(self) -> dict:
        """JSON-serialisable description."""
        skip = ("cfg", "kind_params")
        d = {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name not in skip}
        d["ghosts"] = [dataclasses.asdict(g) for g in self.ghosts]
        d["kind_params"] = {k: dataclasses.asdict(v) for k, v in self.kind_params.items()}
        d["bank"] = self.cfg.bank_key()
        return json.loads(json.dumps(d, default=lambda v: np.asarray(v).tolist()))


def sample_lens(cfg: FlareConfig, rng: np.random.Generator) -> Lens:
    """Draw one lens from ``cfg``'s ranges: the ``scatter`` lens and light first (the same
    draws as before kinds existed), then which kinds it has and their parameters."""
    lens = _sample_scatter_lens(cfg, rng)
    lens.kinds = _draw_kinds(cfg, rng)
    lens.kind_params = {k: _SAMPLERS[k](getattr(cfg, k), rng) for k in lens.kinds
                        if k != "scatter"}
    return lens


def _draw_kinds(cfg: FlareConfig, rng: np.random.Generator) -> tuple[str, ...]:
    """The kinds of one lens: all of a single kind (no draw); of several, each with its
    probability, or one of them at random when none came up."""
    if len(cfg.kinds) == 1:
        return cfg.kinds
    on = tuple(k for k in cfg.kinds if rng.random() < cfg.kind_prob(k))
    return on or (cfg.kinds[int(rng.integers(len(cfg.kinds)))],)


def _sample_scatter_lens(cfg: FlareConfig, rng: np.random.Generator) -> Lens:
    """The ``scatter`` kind's lens (PSF, its ghosts and halo) and the light's colour and core."""
    light = blackbody_rgb(_uniform(rng, cfg.light_temperature))
    ghosts = []
    for _ in range(int(rng.integers(cfg.ghost_count[0], cfg.ghost_count[1] + 1))):
        lo, hi = cfg.ghost_hues[int(rng.integers(len(cfg.ghost_hues)))]
        ghosts.append(Ghost(
            t=_uniform(rng, cfg.ghost_t), radius=_uniform(rng, cfg.ghost_radius),
            amplitude=_loguniform(rng, cfg.ghost_amplitude),
            tint=hsv_rgb(rng.uniform(lo, hi), _uniform(rng, cfg.ghost_saturation)),
            ring=bool(rng.random() < cfg.ghost_ring_prob),
            softness=_uniform(rng, cfg.ghost_softness), chroma=_uniform(rng, cfg.ghost_chroma)))
    return Lens(
        cfg=cfg, psf_index=int(rng.integers(cfg.n_psfs)),
        blades=int(rng.choice(cfg.aperture_blades)), blade_rotation=rng.uniform(0, np.pi),
        psf_rotation=rng.uniform(0, 2 * np.pi), psf_extent=_uniform(rng, cfg.psf_extent),
        scatter_flux=_loguniform(rng, cfg.scatter_flux), ghosts=ghosts,
        glare_amplitude=_loguniform(rng, cfg.glare_amplitude),
        glare_width=_uniform(rng, cfg.glare_width),
        glare_tint=hsv_rgb(rng.uniform(0, 360), rng.uniform(0.0, 0.25)), light_rgb=light,
        core_radius=_uniform(rng, cfg.core_radius), core_level=_uniform(rng, cfg.core_level))


_SAMPLERS = {"starburst": sample_starburst, "ghosts": sample_ghost_chain,
             "streaks": sample_streaks, "glare": sample_veiling_glare}
"""Kind -> the sampler of its parameters from ``getattr(FlareConfig, kind)``."""
