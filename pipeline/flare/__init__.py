"""Lens-flare synthesis in linear light: five kinds of flare, summed, with an exact mask.

A bright point light seen through a real lens leaves flare on the sensor; this package
renders it in LINEAR light and adds it to a clean photo. Each kind of flare is its own
generator (parameters drawn once per lens from its config, then a renderer returning the
[H, W, 3] linear light it adds); a lens combines the kinds of ``FlareConfig.kinds``
(``KINDS``), all lit by the same light (position, colour, intensity):

- ``scatter``: the dirty-aperture lens of Wu et al. (ICCV 2021), as this package rendered
  before kinds existed (details below): PSF scattering, a few ghosts and a small halo.
- ``starburst``: aperture-diffraction spikes (:class:`StarburstConfig`), 4-18 of them,
  varied length, width and sharpness, with colour fringes (red spikes longer than blue).
- ``ghosts``: a ghost chain (:class:`GhostChainConfig`) on the line through the light and
  the optical centre, including beyond the centre: circles, 5-9-gons, rings, hard or soft
  edges, coating tints, evenly or randomly spaced.
- ``streaks``: long streaks through the light (:class:`StreakConfig`): one thin anamorphic
  (horizontal) streak, or broad smeared-lens / windshield streaks in 1-4 directions, able to
  cross the frame, falling off with distance.
- ``glare``: veiling glare (:class:`VeilingGlareConfig`): a glow around the light plus a
  broad low-contrast veil and a colour cast that stay under the mask threshold.

The ``scatter`` kind, in detail:

1. **Scattering flare** (streaks, starbursts, colour fringes). Dust, scratches and the
   aperture's shape diffract light. In Fraunhofer optics the point-spread function (PSF)
   of a pupil with transmission ``A`` and wavefront error ``phi`` is
   ``PSF_lambda = |FFT2(A * exp(i * 2 pi phi / lambda))|^2``. ``A`` is a circle or a regular
   polygon (iris blades) with random dust specks (small partly opaque discs) and scratches
   (thin opaque curves); ``phi`` is defocus, the Zernike term ``a * (2 rho^2 - 1)``. The FFT
   grid of wavelength ``lambda`` has a pixel pitch proportional to ``lambda``, so each
   monochromatic PSF is magnified by ``lambda / lambda0`` (``lambda0 = 550 nm``) into a
   common image grid, weighted by approximate camera R, G, B spectral responses (Gaussians)
   and summed over ``n_wavelengths`` wavelengths in 380-740 nm. Each channel of the RGB PSF
   is normalised to sum 1 (a white light's energy is conserved), so the scatter layer is
   ``flux * PSF`` placed at the light. Long thin scratches give the long streaks, polygon
   apertures the diffraction spikes, dust a speckled halo, and the per-wavelength scaling the
   rainbow tails.
2. **Reflective flare (ghosts)**. Inter-reflections between lens surfaces image the aperture
   again, defocused, at points on the line through the light source and the optical centre
   ``c``: ghost ``k`` sits at ``c + t_k * (light - c)`` (``t = -1`` is the point mirrored
   through the centre, ``t = 1`` the light itself) and its size grows with ``|t|``. Each ghost
   is the aperture's shape (disc or polygon, filled or a ring brighter at its rim) with a soft
   edge, a colour tint from the anti-reflection coating and a slight chromatic size spread.
3. **Glare / halo**: a falloff ``(1 + (d / w)^2)^-1.5`` around the light.

Whatever the kinds, **the light source core** is a small saturated disc (the light itself,
not flare).

The layers are kept apart (:class:`FlareLayers`): ``flare`` (every kind summed), ``core`` and
a ground-truth flare-occupancy ``mask``. Compositing (:func:`apply_flare`) converts the photo
from sRGB to linear, adds ``flare + core``, applies gain and noise, clips and converts
back. The mask rule (:func:`mask_threshold`, :func:`flare_mask`) marks where the flare is
visible: the linear luminance of the summed flare above
``max(mask_abs_threshold, mask_rel_threshold * background luminance)`` (defaults
``MASK_THRESHOLD`` = 0.012 and ``MASK_RELATIVE`` = 0.1), with the core disc excluded (the
light source itself is not flare). The background luminance is smoothed (``mask_smooth``)
first so that masks follow regions rather than texture. Faint layers of several kinds can
add up to a masked pixel that none of them would mark alone.

PSFs are the only costly part (hundreds of FFTs), so a bank of ``n_psfs`` RGB PSFs is built
once per bank configuration and cached in memory and on disk
(``$DEFLARE_CACHE`` or ``~/.cache/deflare-scene``, ``psf_bank_<hash>.npz``). A lens
(:class:`Lens`, sampled once per scene) picks one PSF of the bank, a rotation and a scale,
its ghost layout and tints, and the parameters of its other kinds; rendering a lens at a
light position is then a few warps, small patch draws and thin bands of pixels. Everything
is deterministic given the random generator (the compositing noise seeds OpenCV's generator
from it). See docs/flare_kinds.md for pictures of each kind.

Typical use (a training composite; about 30 ms CPU at 512x512)::

    cfg = FlareConfig()                       # FlareConfig.unseen() for held-out flare
    rng = np.random.default_rng(seed)
    flared, layers = synthesize(photo_uint8, cfg, rng)   # flared: float32 sRGB [0, 1]
    target = layers.mask                                 # [H, W] bool, core excluded

and for one lens seen from several places (the synth stage)::

    lens = sample_lens(cfg, rng)
    layers = render_flare(lens, light_xy, (H, W), rng, intensity, srgb_to_linear(photo))
    flared = apply_flare(photo, layers)

The package, one module per part (each kind of flare is its own generator with its own
parameters: a config of ranges, the parameters one lens draws from it, a renderer):

- ``common``: the mask rule's constants, colour and pixel helpers shared by the kinds;
- ``starburst``, ``ghosts``, ``streaks``, ``glare``: the four kinds beside ``scatter``;
- ``scatter``: apertures, PSFs and their cached bank, the dirty-aperture lens's layer;
- ``config``: :class:`FlareConfig`, every range, and the checks of kind names;
- ``lens``: :class:`Lens` and :func:`sample_lens` (one lens per scene);
- ``compose``: a lens rendered at a light with its exact mask, compositing, and
  :func:`synthesize` (one training composite).

Everything is importable from ``pipeline.flare`` itself.
"""

from __future__ import annotations

from pipeline.flare.common import (  # noqa: F401
    KINDS,
    LAMBDA0,
    LUMA,
    MASK_RELATIVE,
    MASK_THRESHOLD,
    VEIL_CAP,
    blackbody_rgb,
    hsv_rgb,
    luminance,
    spectral_response,
    to_float_image,
)
from pipeline.flare.compose import (  # noqa: F401
    FlareLayers,
    apply_flare,
    flare_mask,
    mask_threshold,
    render_flare,
    render_kind,
    sample_intensity,
    sample_light_xy,
    synthesize,
)
from pipeline.flare.config import (  # noqa: F401
    FlareConfig,
    check_kinds,
    parse_kind_probs,
    parse_kinds,
)
from pipeline.flare.ghosts import (  # noqa: F401
    Ghost,
    GhostChain,
    GhostChainConfig,
    render_ghost_chain,
    sample_ghost_chain,
)
from pipeline.flare.glare import (  # noqa: F401
    VeilingGlare,
    VeilingGlareConfig,
    render_veiling_glare,
    sample_veiling_glare,
)
from pipeline.flare.lens import (  # noqa: F401
    Lens,
    sample_lens,
)
from pipeline.flare.scatter import (  # noqa: F401
    aperture_psf,
    build_psf_bank,
    cache_dir,
    make_aperture,
    psf_bank,
)
from pipeline.flare.starburst import (  # noqa: F401
    Starburst,
    StarburstConfig,
    render_starburst,
    sample_starburst,
)
from pipeline.flare.streaks import (  # noqa: F401
    STREAK_FLOOR,
    Streak,
    StreakConfig,
    Streaks,
    render_streaks,
    sample_streaks,
)

__all__ = [
    "FlareConfig",
    "FlareLayers",
    "Ghost",
    "GhostChain",
    "GhostChainConfig",
    "KINDS",
    "LAMBDA0",
    "LUMA",
    "Lens",
    "MASK_RELATIVE",
    "MASK_THRESHOLD",
    "STREAK_FLOOR",
    "Starburst",
    "StarburstConfig",
    "Streak",
    "StreakConfig",
    "Streaks",
    "VEIL_CAP",
    "VeilingGlare",
    "VeilingGlareConfig",
    "aperture_psf",
    "apply_flare",
    "blackbody_rgb",
    "build_psf_bank",
    "cache_dir",
    "check_kinds",
    "flare_mask",
    "hsv_rgb",
    "luminance",
    "make_aperture",
    "mask_threshold",
    "parse_kind_probs",
    "parse_kinds",
    "psf_bank",
    "render_flare",
    "render_ghost_chain",
    "render_kind",
    "render_starburst",
    "render_streaks",
    "render_veiling_glare",
    "sample_ghost_chain",
    "sample_lens",
    "sample_light_xy",
    "sample_starburst",
    "sample_streaks",
    "sample_veiling_glare",
    "spectral_response",
    "synthesize",
    "to_float_image",
]
