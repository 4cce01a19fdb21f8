"""Lens-flare synthesis in linear light: five kinds of flare, summed, with an exact mask.

A bright point light seen through a real lens leaves flare on the sensor; this module
renders it in LINEAR light and adds it to a clean photo. Each kind of flare is its own
generator (parameters drawn once per lens from its config, then a renderer returning the
[H, W, 3] linear light it adds); a lens combines the kinds of ``FlareConfig.kinds``
(``KINDS``), all lit by the same light (position, colour, intensity):

- ``scatter``: the dirty-aperture lens of Wu et al. (ICCV 2021), as this module rendered
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
"""

from __future__ import annotations

import colorsys
import dataclasses
import hashlib
import json
import math
import os
from dataclasses import dataclass, field, replace
from pathlib import Path

import cv2
import numpy as np

from pipeline.colour import fast_pow as _pow
from pipeline.colour import image_to_linear, linear_to_srgb
from pipeline.errors import UserError

LAMBDA0 = 550.0  # nm, reference wavelength of the PSF grid
LUMA = np.array([0.2126, 0.7152, 0.0722], np.float32)  # linear-light luminance weights

KINDS: tuple[str, ...] = ("starburst", "ghosts", "streaks", "glare", "scatter")
"""The kinds of flare a lens can combine (``FlareConfig.kinds``); see the module docstring."""
MASK_THRESHOLD = 0.012
"""The mask rule's absolute threshold: a pixel is flare where the linear-light luminance of
all the added flare (every kind summed, the core excluded) exceeds this, and also exceeds
``MASK_RELATIVE`` x the smoothed background luminance (``FlareConfig.mask_abs_threshold``)."""
MASK_RELATIVE = 0.1
"""The mask rule's relative threshold (``FlareConfig.mask_rel_threshold``)."""
VEIL_CAP = 0.8
"""The veiling glare's broad veil and colour cast together stay below this fraction of the
absolute mask threshold (in luminance) at any intensity, so they never enter the mask on
their own; only its glow near the light does."""


# --------------------------------------------------------------------------- colour
# srgb_to_linear, linear_to_srgb, image_to_linear: pipeline/colour.py (the one sRGB pair)
def to_float_image(image: np.ndarray) -> np.ndarray:
    """[H, W, 3] uint8 (0-255) or float (0-1) -> float32 in [0, 1]."""
    image = np.asarray(image)
    if image.dtype == np.uint8:
        return image.astype(np.float32) / 255.0
    return np.clip(image.astype(np.float32), 0.0, 1.0)


def luminance(rgb: np.ndarray) -> np.ndarray:
    """[H, W, 3] linear RGB -> [H, W] float32 luminance (Rec. 709 weights)."""
    rgb = np.ascontiguousarray(rgb, np.float32)
    return cv2.transform(rgb, LUMA[None]).reshape(rgb.shape[:-1])


def spectral_response(wavelengths: np.ndarray) -> np.ndarray:
    """[3, L] approximate camera R, G, B sensitivities (Gaussian bands) at ``wavelengths`` nm."""
    centres = np.array([600.0, 535.0, 455.0])[:, None]
    widths = np.array([38.0, 40.0, 30.0])[:, None]
    r = np.exp(-0.5 * ((wavelengths[None] - centres) / widths) ** 2)
    r[0] += 0.15 * np.exp(-0.5 * ((wavelengths - 440.0) / 20.0) ** 2)  # red's blue bump
    return r


def blackbody_rgb(temperature: float) -> np.ndarray:
    """[3] linear RGB of a black body at ``temperature`` K through :func:`spectral_response`,
    relative to a 6500 K source (so 6500 K is white) and scaled to max 1."""
    lam = np.linspace(380.0, 740.0, 73)
    resp = spectral_response(lam)

    def planck(t: float) -> np.ndarray:
        lm = lam * 1e-9
        return 1.0 / (lm ** 5 * (np.exp(1.4388e-2 / (lm * t)) - 1.0))

    rgb = (resp @ planck(temperature)) / (resp @ planck(6500.0))
    return (rgb / rgb.max()).astype(np.float32)


def hsv_rgb(hue_deg: float, sat: float) -> np.ndarray:
    """[3] a linear-RGB tint of a hue (degrees) and saturation, max channel 1."""
    return np.array(colorsys.hsv_to_rgb((hue_deg % 360) / 360.0, sat, 1.0), np.float32)


# --------------------------------------------------------------------------- config
@dataclass
class StarburstConfig:
    """Ranges of the aperture-diffraction starburst (kind ``starburst``): thin spikes from the
    light, evenly spaced in angle. Lengths and widths are fractions of the image diagonal."""

    prob: float = 0.5
    """Probability that a lens has a starburst (when it is one of several ``kinds``)."""
    spikes: tuple[int, int] = (4, 18)
    """Number of spikes (rays from the light), inclusive."""
    angle_jitter: float = 0.03
    """Std (radians) of each spike's angle about the even spacing."""
    length: tuple[float, float] = (0.05, 0.5)
    """Log-uniform. Length ``L`` of the longest spike (green channel)."""
    length_spread: tuple[float, float] = (0.0, 0.6)
    """How unequal the spikes are: each is ``L x U(1 - spread, 1)`` long."""
    width: tuple[float, float] = (0.0008, 0.004)
    """Log-uniform. Gaussian sigma across a spike at the light (at least 0.6 pixel); spikes
    taper to half of it at their tips."""
    sharpness: tuple[float, float] = (1.0, 4.0)
    """Exponent ``p`` of the fall-off along a spike, ``(1 - s / L)^p``: high is bright near the
    light and faint along most of the spike."""
    amplitude: tuple[float, float] = (0.08, 1.0)
    """Log-uniform. Linear value of a spike at the light, at intensity 1."""
    chroma: tuple[float, float] = (0.0, 0.12)
    """Colour fringes: red spikes are ``1 + chroma`` times as long as green, blue ``1 - chroma``."""
    saturation: tuple[float, float] = (0.0, 0.2)
    """Saturation of a random tint of the whole starburst."""


@dataclass
class GhostChainConfig:
    """Ranges of the ghost chain (kind ``ghosts``): reflections of the aperture on the line
    through the light and the optical centre ``c``, at ``c + t (light - c)`` (``t = 1`` the
    light, 0 the centre, -1 the light mirrored through the centre). Sizes are fractions of the
    image diagonal."""

    prob: float = 0.5
    """Probability that a lens has a ghost chain (when it is one of several ``kinds``)."""
    count: tuple[int, int] = (3, 10)
    """Number of ghosts, inclusive."""
    t: tuple[float, float] = (-2.0, 1.2)
    """Range of the ghosts' positions ``t`` (below -1: beyond the mirrored light)."""
    regular_prob: float = 0.5
    """Probability of an evenly spaced chain (otherwise positions are uniform in ``t``)."""
    spacing: tuple[float, float] = (0.1, 0.45)
    """Step in ``t`` of an evenly spaced chain (shrunk to fit ``t``)."""
    sides: tuple[int, ...] = (0, 5, 6, 7, 8, 9)
    """Shapes drawn from (one per chain): 0 = circle, n = regular n-gon."""
    radius: tuple[float, float] = (0.006, 0.07)
    """Log-uniform. Radius of each ghost."""
    amplitude: tuple[float, float] = (0.02, 0.3)
    """Log-uniform. Peak linear value of each ghost at intensity 1."""
    ring_prob: float = 0.3
    """Probability that a ghost is a ring (bright rim) rather than a filled shape."""
    softness: tuple[float, float] = (0.01, 0.8)
    """Log-uniform. Edge width, fraction of the radius (0.01: hard edge, 0.8: a soft blob)."""
    hues: tuple[tuple[float, float], ...] = ((0.0, 360.0),)
    """Hue ranges (degrees) of the ghosts' tints (one range drawn per ghost)."""
    saturation: tuple[float, float] = (0.1, 0.8)
    """Saturation of the ghosts' tints."""
    chroma: tuple[float, float] = (0.0, 0.1)
    """Chromatic size spread: red radius x (1 + s), blue x (1 - s)."""


@dataclass
class StreakConfig:
    """Ranges of long broad streaks (kind ``streaks``) through the light: an anamorphic
    (horizontal, thin, bluish) streak, or smeared-lens / windshield streaks in one or several
    directions. Along a streak the light falls off as ``0.7 exp(-|s| / L) + 0.3 exp(-|s| /
    0.1 L)``; across it is Gaussian, its sigma widening as ``w (1 + spread |s| / L)``.
    Lengths and widths are fractions of the image diagonal."""

    prob: float = 0.35
    """Probability that a lens has streaks (when it is one of several ``kinds``)."""
    anamorphic_prob: float = 0.5
    """Probability that the streak is anamorphic rather than smeared."""
    anamorphic_tilt: float = 3.0
    """Largest tilt of an anamorphic streak from the horizontal (degrees)."""
    anamorphic_length: tuple[float, float] = (0.4, 2.0)
    """Log-uniform. Fall-off length ``L`` of an anamorphic streak (1 or more: it crosses the
    frame)."""
    anamorphic_width: tuple[float, float] = (0.001, 0.005)
    """Log-uniform. Sigma ``w`` across an anamorphic streak at the light (at least 0.6 px)."""
    anamorphic_hues: tuple[float, float] = (190.0, 235.0)
    """Hue range (degrees) of an anamorphic streak's tint (blues)."""
    anamorphic_saturation: tuple[float, float] = (0.2, 0.8)
    """Saturation of an anamorphic streak's tint."""
    count: tuple[int, int] = (1, 4)
    """Number of smeared streaks (directions uniform in angle), inclusive."""
    length: tuple[float, float] = (0.15, 1.0)
    """Log-uniform. Fall-off length ``L`` of a smeared streak."""
    width: tuple[float, float] = (0.004, 0.02)
    """Log-uniform. Sigma ``w`` across a smeared streak at the light."""
    spread: tuple[float, float] = (0.3, 3.0)
    """Widening of a smeared streak with distance (anamorphic streaks: a tenth of it)."""
    saturation: tuple[float, float] = (0.0, 0.3)
    """Saturation of a smeared streak's tint (any hue)."""
    amplitude: tuple[float, float] = (0.03, 0.4)
    """Log-uniform. Linear value at the light at intensity 1 (further smeared streaks x
    U(0.3, 1))."""


@dataclass
class VeilingGlareConfig:
    """Ranges of the veiling glare (kind ``glare``): a glow around the light
    ``a (1 + (d / w)^2)^-2``, a broad low-contrast veil ``(1 + (d / W)^2)^-1`` and a uniform
    colour cast. Veil and cast together stay below ``VEIL_CAP`` x the absolute mask
    threshold in luminance at any intensity, so only the glow near the light is ever
    masked. Sizes are fractions of the image diagonal."""

    prob: float = 0.4
    """Probability that a lens has veiling glare (when it is one of several ``kinds``)."""
    glow_amplitude: tuple[float, float] = (0.02, 0.3)
    """Log-uniform. Peak linear value of the glow at intensity 1."""
    glow_width: tuple[float, float] = (0.02, 0.1)
    """Half-width ``w`` of the glow."""
    veil_level: tuple[float, float] = (0.2, 0.7)
    """Peak luminance of the veil at intensity 1, fraction of the absolute mask threshold."""
    veil_width: tuple[float, float] = (0.3, 1.5)
    """Half-width ``W`` of the veil (1 or more: it covers the frame)."""
    cast_level: tuple[float, float] = (0.0, 0.3)
    """Luminance of the uniform colour cast at intensity 1, fraction of the threshold."""
    saturation: tuple[float, float] = (0.05, 0.5)
    """Saturation of the veil's and cast's tint (any hue); the glow takes half of it."""


@dataclass
class FlareConfig:
    """Ranges from which lenses, lights and flares are drawn. ``(lo, hi)`` pairs are uniform
    unless noted log-uniform. Sizes are fractions of the image diagonal unless noted.

    ``kinds`` chooses the kinds of flare a lens may combine; the flat fields from ``psf_size``
    to ``glare_width`` parametrise the ``scatter`` kind (the dirty-aperture lens), the nested
    ``starburst``, ``ghosts``, ``streaks`` and ``glare`` configs the other kinds. The light's
    colour, core, intensity and position are shared by all kinds."""

    # PSF bank (changing any of these builds a new bank)
    psf_size: int = 512
    """Side of the square FFT grid of each PSF in the bank (pixels)."""
    n_psfs: int = 12
    """Number of dirty apertures (RGB PSFs) in the bank."""
    n_wavelengths: int = 41
    """Wavelengths sampled evenly in 380-740 nm for each PSF."""
    aperture_radius: float = 0.25
    """Aperture radius as a fraction of ``psf_size`` (sets the Airy core size)."""
    aperture_blades: tuple[int, ...] = (0, 6, 8)
    """Aperture shapes drawn from: 0 = circle, n = regular n-gon (iris blades)."""
    dust_count: tuple[int, int] = (30, 250)
    """Number of dust specks on the aperture."""
    dust_radius: tuple[float, float] = (0.005, 0.05)
    """Dust speck radius, fraction of the aperture radius."""
    scratch_count: tuple[int, int] = (1, 10)
    """Number of scratches (thin curves) on the aperture."""
    scratch_width: tuple[float, float] = (0.5, 2.0)
    """Scratch width in FFT-grid pixels."""
    defocus_waves: tuple[float, float] = (0.0, 0.8)
    """Defocus Zernike coefficient, in waves at 550 nm."""
    bank_seed: int = 0
    """Seed of the bank's apertures."""

    # lens (sampled once per scene by sample_lens)
    psf_extent: tuple[float, float] = (0.7, 1.8)
    """Side of the PSF grid on the image, as a fraction of the image diagonal."""
    scatter_flux: tuple[float, float] = (3e3, 6e4)
    """Log-uniform. Flux of the light in the scatter layer (x PSF, per PSF-grid pixel)."""
    ghost_count: tuple[int, int] = (2, 8)
    """Number of ghosts, inclusive."""
    ghost_t: tuple[float, float] = (-1.6, 1.5)
    """Ghost position parameter ``t``: centre ``c + t (light - c)``."""
    ghost_radius: tuple[float, float] = (0.01, 0.06)
    """Ghost radius at ``|t| = 1``; radius = this * (0.35 + |t|)."""
    ghost_amplitude: tuple[float, float] = (0.02, 0.3)
    """Log-uniform. Peak linear value of a ghost at intensity 1."""
    ghost_ring_prob: float = 0.35
    """Probability that a ghost is a ring (bright rim) rather than a filled disc."""
    ghost_softness: tuple[float, float] = (0.03, 0.5)
    """Edge softness of a ghost, fraction of its radius."""
    ghost_hues: tuple[tuple[float, float], ...] = ((70.0, 200.0), (260.0, 330.0))
    """Hue ranges (degrees) of ghost tints: greens/cyans and purples/magentas."""
    ghost_saturation: tuple[float, float] = (0.1, 0.7)
    """Saturation of ghost tints."""
    ghost_chroma: tuple[float, float] = (0.0, 0.06)
    """Chromatic size spread: red radius x (1 + s), blue x (1 - s)."""
    ghost_flicker: float = 0.1
    """Log-normal sigma of per-render ghost amplitude changes (angle of incidence)."""
    glare_amplitude: tuple[float, float] = (0.01, 0.15)
    """Log-uniform. Peak linear value of the veiling glare at intensity 1."""
    glare_width: tuple[float, float] = (0.01, 0.08)
    """Half-width ``w`` of the glare falloff."""
    light_temperature: tuple[float, float] = (2700.0, 8000.0)
    """Colour temperature of the light (K); tints flare and core."""
    core_radius: tuple[float, float] = (0.003, 0.012)
    """Radius of the light source core disc."""
    core_level: tuple[float, float] = (2.0, 8.0)
    """Linear value of the core (above 1: saturated)."""

    # one sample (synthesize)
    intensity: tuple[float, float] = (0.4, 2.5)
    """Log-uniform. Multiplier of the lens's flare (every kind; not the core)."""
    light_outside_prob: float = 0.15
    """Probability that synthesize puts the light outside the frame (flare still enters)."""
    light_outside_margin: float = 0.25
    """How far outside the frame such a light can be."""
    noise: tuple[float, float] = (0.0, 0.004)
    """Std of Gaussian noise added in linear light."""
    gain: tuple[float, float] = (0.85, 1.15)
    """Exposure gain applied in linear light before clipping."""

    # ground-truth mask
    mask_abs_threshold: float = MASK_THRESHOLD
    """Flare is visible where its linear luminance exceeds this ..."""
    mask_rel_threshold: float = MASK_RELATIVE
    """... and this fraction of the background's linear luminance (both must hold)."""
    mask_smooth: float = 0.004
    """Gaussian sigma (fraction of the diagonal) smoothing the background luminance used by
    the relative threshold."""

    # kinds of flare
    kinds: tuple[str, ...] = KINDS
    """Kinds of flare to combine (of ``KINDS``). With one kind every lens has it; with several,
    each is drawn with its probability (``scatter_prob``, ``<kind>.prob``) and a lens that
    drew none gets one of them at random. ``("scatter",)`` reproduces the synthesizer as it
    was before kinds existed, draw for draw."""
    scatter_prob: float = 0.75
    """Probability that a lens has the ``scatter`` kind (when it is one of several ``kinds``)."""
    starburst: StarburstConfig = field(default_factory=StarburstConfig)
    """Ranges of the ``starburst`` kind."""
    ghosts: GhostChainConfig = field(default_factory=GhostChainConfig)
    """Ranges of the ``ghosts`` kind (a ghost chain; the ``ghost_*`` fields above are the
    ``scatter`` lens's own few ghosts)."""
    streaks: StreakConfig = field(default_factory=StreakConfig)
    """Ranges of the ``streaks`` kind."""
    glare: VeilingGlareConfig = field(default_factory=VeilingGlareConfig)
    """Ranges of the ``glare`` kind (veiling glare; the ``glare_*`` fields above are the
    ``scatter`` lens's small halo)."""

    def __post_init__(self) -> None:
        self.kinds = check_kinds(self.kinds, "FlareConfig.kinds")

    @classmethod
    def unseen(cls) -> FlareConfig:
        """Settings the default config's ``scatter`` kind never draws (out-of-distribution
        FMG evaluation): pentagon/heptagon/nonagon apertures, more ghosts, red/orange/blue
        ghost tints, more scratches and stronger defocus; a different bank seed. It keeps to
        the ``scatter`` kind, so it draws exactly what it drew before kinds existed."""
        return cls(kinds=("scatter",), aperture_blades=(5, 7, 9), ghost_count=(9, 13),
                   ghost_hues=((0.0, 60.0), (205.0, 255.0)), scratch_count=(11, 18),
                   defocus_waves=(0.9, 1.5), bank_seed=1)

    def kind_prob(self, kind: str) -> float:
        """The probability of ``kind`` when it is one of several ``kinds``."""
        return self.scatter_prob if kind == "scatter" else getattr(self, kind).prob

    def with_kind_probs(self, probs: dict[str, float]) -> FlareConfig:
        """A copy in which each kind of ``probs`` is drawn with the given probability."""
        out = replace(self)
        for kind, p in probs.items():
            if kind == "scatter":
                out.scatter_prob = p
            else:
                setattr(out, kind, replace(getattr(self, kind), prob=p))
        return out

    def bank_fields(self) -> dict:
        names = ("psf_size", "n_psfs", "n_wavelengths", "aperture_radius", "aperture_blades",
                 "dust_count", "dust_radius", "scratch_count", "scratch_width",
                 "defocus_waves", "bank_seed")
        return {n: getattr(self, n) for n in names}

    def bank_key(self) -> str:
        text = json.dumps({"v": 1, **self.bank_fields()}, sort_keys=True)
        return hashlib.blake2b(text.encode(), digest_size=8).hexdigest()


def check_kinds(kinds, option: str = "--kinds") -> tuple[str, ...]:
    """``kinds`` (names of ``KINDS``) as a tuple without repeats; a one-line
    :class:`UserError` naming ``option`` for an unknown kind or none at all."""
    kinds = (kinds,) if isinstance(kinds, str) else tuple(kinds)
    allowed = ", ".join(KINDS)
    for k in kinds:
        if k not in KINDS:
            raise UserError(f"{option} {','.join(map(str, kinds))!r}: unknown flare kind "
                            f"{k!r}; allowed kinds: {allowed}")
    if not kinds:
        raise UserError(f"{option} is empty: give one or more of {allowed}")
    return tuple(dict.fromkeys(kinds))


def parse_kind_probs(items, option: str = "--kind-probs") -> dict[str, float]:
    """('streaks=0.7', 'ghosts=0.6') or 'streaks=0.7,ghosts=0.6' -> {'streaks': 0.7, ...};
    a one-line :class:`UserError` naming ``option`` for an unknown kind or a probability
    outside [0, 1]."""
    items = items.split(",") if isinstance(items, str) else items
    out: dict[str, float] = {}
    for item in (i.strip() for i in items):
        if not item:
            continue
        kind, sep, value = item.partition("=")
        try:
            p = float(value)
        except ValueError:
            p = math.nan
        if not sep or not 0 <= p <= 1:
            raise UserError(f"{option} {item!r}: give KIND=P with P between 0 and 1, e.g. "
                            "streaks=0.7")
        out[check_kinds((kind.strip(),), option)[0]] = p
    return out


def parse_kinds(text: str, option: str = "--kinds") -> tuple[str, ...]:
    """'starburst,ghosts' -> ('starburst', 'ghosts'), checked by :func:`check_kinds`."""
    return check_kinds([k.strip() for k in text.split(",") if k.strip()], option)


def _uniform(rng: np.random.Generator, r: tuple[float, float]) -> float:
    return float(rng.uniform(r[0], r[1]))


def _loguniform(rng: np.random.Generator, r: tuple[float, float]) -> float:
    return float(np.exp(rng.uniform(np.log(r[0]), np.log(r[1]))))


# --------------------------------------------------------------------------- apertures
def _polygon_gauge(x: np.ndarray, y: np.ndarray, blades: int, rotation: float
                   ) -> tuple[np.ndarray, float]:
    """(gauge, apothem factor): a circle (blades 0) or regular n-gon of circumradius ``r``
    is ``gauge <= r * factor``; ``gauge - r * factor`` is an approximate signed distance
    (pixels, negative inside). ``x``, ``y`` broadcast (float32)."""
    if blades == 0:
        return np.sqrt(x * x + y * y), 1.0
    angles = rotation + 2 * np.pi * np.arange(blades) / blades
    proj = x * float(np.cos(angles[0])) + y * float(np.sin(angles[0]))
    for a in angles[1:]:
        np.maximum(proj, x * float(np.cos(a)) + y * float(np.sin(a)), out=proj)
    return proj, float(np.cos(np.pi / blades))


def _polygon_sdf(x: np.ndarray, y: np.ndarray, radius: float, blades: int,
                 rotation: float) -> np.ndarray:
    """Approximate signed distance (pixels, negative inside) to a circle (blades 0) or a
    regular n-gon of circumradius ``radius``."""
    gauge, factor = _polygon_gauge(x, y, blades, rotation)
    return gauge - np.float32(radius * factor)


def make_aperture(size: int, radius: float, blades: int, cfg: FlareConfig,
                  rng: np.random.Generator) -> np.ndarray:
    """[size, size] float32 transmission of a dirty aperture (antialiased shape x dust x
    scratches); ``radius`` in pixels, centred on the grid."""
    c = (size - 1) / 2.0
    yy, xx = np.mgrid[0:size, 0:size].astype(np.float32) - c
    shape = np.clip(0.5 - _polygon_sdf(xx, yy, radius, blades, rng.uniform(0, np.pi)), 0, 1)
    absorb = np.zeros((size, size), np.float32)
    sh = 16  # cv2 fixed-point shift for sub-pixel drawing
    for _ in range(int(rng.integers(cfg.dust_count[0], cfg.dust_count[1] + 1))):
        r = radius * _loguniform(rng, cfg.dust_radius)
        p = c + rng.uniform(-1, 1, 2) * radius
        cv2.circle(absorb, tuple(int(v * sh) for v in p), max(int(r * sh), 1),
                   float(rng.uniform(0.3, 1.0)), -1, cv2.LINE_AA, shift=4)
    for _ in range(int(rng.integers(cfg.scratch_count[0], cfg.scratch_count[1] + 1))):
        pts = _scratch_points(c, radius, rng)
        w = _uniform(rng, cfg.scratch_width)
        cv2.polylines(absorb, [np.round(pts * sh).astype(np.int32)], False,
                      float(rng.uniform(0.5, 1.0)) * min(w, 1.0), max(int(round(w)), 1),
                      cv2.LINE_AA, shift=4)
    return (shape * (1.0 - np.clip(absorb, 0, 1))).astype(np.float32)


def _scratch_points(c: float, radius: float, rng: np.random.Generator) -> np.ndarray:
    """[P, 2] a gently curved scratch (quadratic Bezier) crossing part of the aperture."""
    p0 = c + rng.uniform(-1, 1, 2) * radius
    ang = rng.uniform(0, np.pi)
    length = radius * rng.uniform(0.3, 2.0)
    p2 = p0 + length * np.array([np.cos(ang), np.sin(ang)])
    p1 = (p0 + p2) / 2 + rng.normal(0, 0.15 * length, 2)
    s = np.linspace(0, 1, 24)[:, None]
    return (1 - s) ** 2 * p0 + 2 * (1 - s) * s * p1 + s ** 2 * p2


def aperture_psf(aperture: np.ndarray, defocus: float, cfg: FlareConfig) -> np.ndarray:
    """[S, S, 3] float32 RGB PSF of a pupil (see the module docstring); each channel sums 1.

    ``aperture`` [a, a] transmission (a <= S) is zero-padded to the S x S FFT grid (padding
    position changes only a phase ramp, not ``|FFT|^2``); ``defocus`` in waves at 550 nm.
    """
    from scipy import fft as sfft

    S, a = cfg.psf_size, aperture.shape[0]
    yy, xx = np.mgrid[0:a, 0:a].astype(np.float32) - (a - 1) / 2.0
    rho2 = (xx * xx + yy * yy) / (cfg.aperture_radius * S) ** 2
    zern = (2.0 * rho2 - 1.0).astype(np.float32)
    lams = np.linspace(380.0, 740.0, cfg.n_wavelengths)
    resp = spectral_response(lams)  # [3, L]
    out = np.zeros((S, S, 3), np.float64)
    c = S // 2  # fftshift puts the zero frequency here
    for i, lam in enumerate(lams):
        field_ = aperture * np.exp(1j * (2 * np.pi * defocus * LAMBDA0 / lam) * zern)
        psf = np.abs(sfft.fft2(field_.astype(np.complex64), s=(S, S), workers=1)) ** 2
        psf = np.fft.fftshift(psf).astype(np.float32)
        psf /= psf.sum()
        s = lam / LAMBDA0  # the grid pitch grows with lambda: magnify about the centre
        m = np.array([[s, 0, (1 - s) * c], [0, s, (1 - s) * c]], np.float32)
        psf = cv2.warpAffine(psf, m, (S, S), flags=cv2.INTER_LINEAR) / (s * s)
        out += psf[..., None] * resp[:, i]
    out = np.maximum(out, 0)
    return (out / out.sum(axis=(0, 1), keepdims=True)).astype(np.float32)


# --------------------------------------------------------------------------- PSF bank
_BANKS: dict[str, np.ndarray] = {}


def cache_dir() -> Path:
    """Where PSF banks are cached: ``$DEFLARE_CACHE`` or ``~/.cache/deflare-scene``."""
    env = os.environ.get("DEFLARE_CACHE")
    return Path(env) if env else Path.home() / ".cache" / "deflare-scene"


def build_psf_bank(cfg: FlareConfig, progress: bool = False) -> np.ndarray:
    """[n_psfs, S, S, 3] float32 RGB PSFs of random dirty apertures (not cached)."""
    rng = np.random.default_rng([cfg.bank_seed, 7919])
    S = cfg.psf_size
    radius = cfg.aperture_radius * S
    a = int(2 * np.ceil(radius) + 4)
    bank = np.zeros((cfg.n_psfs, S, S, 3), np.float32)
    items = range(cfg.n_psfs)
    if progress:
        from pipeline.progress import track
        items = track(items, "Building lens PSF bank (once)")
    for k in items:
        blades = int(rng.choice(cfg.aperture_blades))
        ap = make_aperture(a, radius, blades, cfg, rng)
        bank[k] = aperture_psf(ap, _uniform(rng, cfg.defocus_waves), cfg)
    return bank


def psf_bank(cfg: FlareConfig, progress: bool = False) -> np.ndarray:
    """The cached PSF bank of ``cfg`` ([n_psfs, S, S, 3] float32), built on first use."""
    key = cfg.bank_key()
    if key in _BANKS:
        return _BANKS[key]
    path = cache_dir() / f"psf_bank_{key}.npz"
    bank = None
    if path.is_file():
        try:
            with np.load(path) as z:
                bank = z["psfs"].astype(np.float32)
        except (OSError, ValueError, KeyError):
            bank = None  # a damaged cache file is rebuilt
    if bank is None or bank.shape != (cfg.n_psfs, cfg.psf_size, cfg.psf_size, 3):
        bank = build_psf_bank(cfg, progress)
        _save_bank(path, bank, cfg)
    _BANKS[key] = bank
    return bank


def _save_bank(path: Path, bank: np.ndarray, cfg: FlareConfig) -> None:
    from pipeline.workspace import atomic_path

    try:
        with atomic_path(path) as tmp, open(tmp, "wb") as f:
            np.savez(f, psfs=bank, config=json.dumps(cfg.bank_fields()))
    except OSError:  # a read-only cache only costs a rebuild next time
        pass


# --------------------------------------------------------------------------- lens
@dataclass
class Ghost:
    """One reflection ghost of a lens."""

    t: float
    """Position on the light-centre line: ``c + t (light - c)``."""
    radius: float
    """Radius, fraction of the image diagonal."""
    amplitude: float
    """Peak linear value at intensity 1."""
    tint: np.ndarray
    """[3] linear RGB tint (max 1)."""
    ring: bool
    """A ring bright at its rim instead of a filled disc."""
    softness: float
    """Edge width, fraction of the radius."""
    chroma: float
    """Chromatic size spread (R x (1 + chroma), B x (1 - chroma))."""


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


# --------------------------------------------------------------------------- rendering
@dataclass
class FlareLayers:
    """What :func:`render_flare` returns; all linear light."""

    flare: np.ndarray
    """[H, W, 3] float32: every kind of flare summed, the core excluded."""
    core: np.ndarray
    """[H, W, 3] float32: the light source itself."""
    mask: np.ndarray
    """[H, W] bool: ground-truth flare occupancy (visible flare, core excluded)."""
    light_xy: tuple[float, float] = (0.0, 0.0)
    """Light position in pixels (x right, y down; may be outside the frame)."""
    ghost_xy: list[tuple[float, float]] = field(default_factory=list)
    """Centres of the ``scatter`` kind's ghosts in pixels, in ``lens.ghosts`` order."""
    kinds: tuple[str, ...] = ()
    """The kinds of flare summed in ``flare`` (the lens's)."""


def _paste(dst: np.ndarray, patch: np.ndarray, x0: int, y0: int) -> None:
    """Add ``patch`` [h, w, C] into ``dst`` [H, W, C] with its top-left at (x0, y0), clipped."""
    H, W = dst.shape[:2]
    h, w = patch.shape[:2]
    xa, ya, xb, yb = max(x0, 0), max(y0, 0), min(x0 + w, W), min(y0 + h, H)
    if xa < xb and ya < yb:
        dst[ya:yb, xa:xb] += patch[ya - y0:yb - y0, xa - x0:xb - x0]


def _render_scatter(lens: Lens, light_xy, size_hw, diag: float) -> np.ndarray:
    """[H, W, 3] the lens's PSF rotated, scaled and centred on the light (flux not applied)."""
    psf = psf_bank(lens.cfg)[lens.psf_index]
    S = psf.shape[0]
    z = lens.psf_extent * diag / S
    cos, sin = z * np.cos(lens.psf_rotation), z * np.sin(lens.psf_rotation)
    c = S // 2
    m = np.array([[cos, -sin, light_xy[0] - cos * c + sin * c],
                  [sin, cos, light_xy[1] - sin * c - cos * c]], np.float32)
    return cv2.warpAffine(psf, m, (size_hw[1], size_hw[0]), flags=cv2.INTER_LINEAR,
                          borderMode=cv2.BORDER_CONSTANT, borderValue=0)


def _ghost_patch(g: Ghost, radius_px: float, blades: int, rotation: float) -> np.ndarray:
    """[n, n, 3] float32 ghost shape (peak about 1 x tint) centred in an odd-sized patch."""
    soft = max(g.softness * radius_px, 0.7)
    half = int(np.ceil(radius_px * (1 + g.chroma) + 2 * soft + 1))
    yy, xx = np.mgrid[-half:half + 1, -half:half + 1].astype(np.float32)
    out = np.empty((2 * half + 1, 2 * half + 1, 3), np.float32)
    gauge, factor = _polygon_gauge(xx, yy, blades, rotation)
    for ch, s in enumerate((1 + g.chroma, 1.0, 1 - g.chroma)):
        r = max(radius_px * s, 1e-3)
        sdf = gauge - np.float32(r * factor)
        alpha = np.clip(0.5 - sdf * np.float32(0.5 / soft), 0, 1)
        alpha = alpha * alpha * (3 - 2 * alpha)  # smoothstep edge
        if g.ring:  # brighter towards the rim
            rim = np.clip(1 + sdf * np.float32(1 / r), 0, 1) ** 4
            alpha *= 0.15 + 0.85 * rim
        out[..., ch] = alpha * np.float32(g.tint[ch])
    return out


def _scalar(rgb: np.ndarray) -> tuple[float, float, float, float]:
    """[3] -> an OpenCV per-channel scalar."""
    return (float(rgb[0]), float(rgb[1]), float(rgb[2]), 0.0)


def _render_glare(lens: Lens, light_xy, size_hw, diag: float) -> np.ndarray:
    """[H, W] glare falloff ``(1 + (d / w)^2)^-1.5`` around the light, peak 1."""
    H, W = size_hw
    w = lens.glare_width * diag
    x = ((np.arange(W, dtype=np.float32) - light_xy[0]) / w) ** 2
    y = ((np.arange(H, dtype=np.float32) - light_xy[1]) / w) ** 2
    return _pow(1.0 + y[:, None] + x[None, :], -1.5)


def _render_core(lens: Lens, light_xy, size_hw, diag: float) -> np.ndarray:
    """[H, W, 3] the light's saturated disc (zero when the light is outside the frame)."""
    core = np.zeros((*size_hw, 3), np.float32)
    r = lens.core_radius * diag
    half = int(np.ceil(r + 2))
    cx, cy = int(round(light_xy[0])), int(round(light_xy[1]))
    yy, xx = np.mgrid[cy - half:cy + half + 1, cx - half:cx + half + 1].astype(np.float32)
    d = np.sqrt((xx - light_xy[0]) ** 2 + (yy - light_xy[1]) ** 2)
    alpha = np.clip(r + 0.5 - d, 0, 1)[..., None]
    tint = 0.5 + 0.5 * lens.light_rgb  # the core reads close to white
    _paste(core, alpha * lens.core_level * tint, cx - half, cy - half)
    return core


# --------------------------------------------------------------------------- other kinds
# Each kind below is a pair: sampled parameters (drawn once per lens from its config) and a
# renderer returning the [H, W, 3] linear light it adds for a light of colour x intensity
# ``rgb`` [3] at pixel ``light_xy``.
def _line_band(origin: tuple[float, float], angle: float, s_range: tuple[float, float],
               half_width: float, size_hw: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """(ys, xs) int arrays [P]: each pixel of the frame (once) within about ``half_width``
    pixels of the line through ``origin`` at ``angle``, from ``s_range[0]`` to ``s_range[1]``
    pixels along it (plus ``half_width`` at both ends)."""
    H, W = size_hw
    ux, uy = float(np.cos(angle)), float(np.sin(angle))
    steep = abs(uy) > abs(ux)  # march along the axis the line is closer to
    om, on_, um, un, nm, nn = ((origin[1], origin[0], uy, ux, H, W) if steep
                               else (origin[0], origin[1], ux, uy, W, H))
    ends = [om + s_range[0] * um, om + s_range[1] * um]
    lo = max(int(np.floor(min(ends) - half_width)), 0)
    hi = min(int(np.ceil(max(ends) + half_width)), nm - 1)
    if lo > hi:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    m = np.arange(lo, hi + 1)
    b = int(np.ceil(half_width / abs(um))) + 1  # |um| >= 0.7: the band across, in pixels
    if 2 * b + 1 >= nn:
        n = np.broadcast_to(np.arange(nn)[None], (len(m), nn))
    else:
        centre = np.round(on_ + (m - om) * (un / um))
        n = np.clip(centre, -2 * b, nn + 2 * b).astype(np.int64)[:, None] + np.arange(-b, b + 1)
    m = np.broadcast_to(m[:, None], n.shape)
    ok = (n >= 0) & (n < nn)
    m, n = m[ok], n[ok]
    return (m, n) if steep else (n, m)


def _along_across(ys: np.ndarray, xs: np.ndarray, origin: tuple[float, float],
                  angle: float) -> tuple[np.ndarray, np.ndarray]:
    """float32 [P] (distance along the direction ``angle``, signed distance across it) of
    pixels from ``origin``."""
    dx = xs.astype(np.float32) - np.float32(origin[0])
    dy = ys.astype(np.float32) - np.float32(origin[1])
    c, s = np.float32(np.cos(angle)), np.float32(np.sin(angle))
    return dx * c + dy * s, dy * c - dx * s


@dataclass
class Starburst:
    """One lens's diffraction starburst (kind ``starburst``; see :class:`StarburstConfig`)."""

    angles: list[float]
    """Direction of each spike (radians; x right, y down)."""
    lengths: list[float]
    """Length of each spike (green channel), fraction of the diagonal."""
    width: float
    """Gaussian sigma across the spikes at the light, fraction of the diagonal."""
    sharpness: float
    """Exponent ``p`` of the fall-off ``(1 - s / L)^p`` along a spike."""
    amplitude: float
    """Linear value at the light at intensity 1."""
    chroma: float
    """Red spikes are ``1 + chroma`` times as long as green, blue ``1 - chroma``."""
    tint: np.ndarray
    """[3] linear RGB tint (max 1)."""


def sample_starburst(cfg: StarburstConfig, rng: np.random.Generator) -> Starburst:
    """Draw a starburst from ``cfg``'s ranges."""
    n = int(rng.integers(cfg.spikes[0], cfg.spikes[1] + 1))
    angles = (rng.uniform(0, 2 * np.pi) + 2 * np.pi * np.arange(n) / n
              + rng.normal(0.0, cfg.angle_jitter, n))
    longest = _loguniform(rng, cfg.length)
    spread = _uniform(rng, cfg.length_spread)
    return Starburst(
        angles=angles.tolist(), lengths=(longest * rng.uniform(1 - spread, 1, n)).tolist(),
        width=_loguniform(rng, cfg.width), sharpness=_uniform(rng, cfg.sharpness),
        amplitude=_loguniform(rng, cfg.amplitude), chroma=_uniform(rng, cfg.chroma),
        tint=hsv_rgb(rng.uniform(0, 360), _uniform(rng, cfg.saturation)))


def render_starburst(p: Starburst, light_xy: tuple[float, float], size_hw: tuple[int, int],
                     rgb: np.ndarray) -> np.ndarray:
    """[H, W, 3] spikes from the light: along a spike (distance ``s``, channel length
    ``L_c``) ``a (1 - s / L_c)^p``, across it Gaussian with sigma ``w (1 - s / 2 L_c)``;
    rounded at the light."""
    H, W = size_hw
    diag = float(np.hypot(H, W))
    out = np.zeros((H, W, 3), np.float32)
    w0 = max(p.width * diag, 0.6)
    colour = (p.amplitude * np.asarray(p.tint) * rgb).astype(np.float32)
    stretch = (1 + p.chroma, 1.0, 1 - p.chroma)
    for angle, length in zip(p.angles, p.lengths, strict=True):
        L = max(length * diag, 1.0)
        ys, xs = _line_band(light_xy, angle, (0.0, L * max(stretch)), 4 * w0, size_hw)
        if len(ys) == 0:
            continue
        s, d = _along_across(ys, xs, light_xy, angle)
        d2 = d * d + np.minimum(s, 0) ** 2  # behind the light: distance to the light
        s = np.maximum(s, 0)
        for c in range(3):
            t = np.minimum(s / np.float32(L * stretch[c]), 1)
            w = np.float32(w0) * (1 - 0.5 * t)
            val = (1 - t) ** np.float32(p.sharpness) * np.exp(-0.5 * d2 / (w * w))
            out[ys, xs, c] += colour[c] * val
    return out


@dataclass
class GhostChain:
    """One lens's ghost chain (kind ``ghosts``; see :class:`GhostChainConfig`). Each ghost's
    ``radius`` is its own (it does not grow with ``|t|``)."""

    blades: int
    """Shape of the ghosts: 0 = circle, n = regular n-gon."""
    rotation: float
    """Rotation of the polygons (radians)."""
    ghosts: list[Ghost]
    """The ghosts, in order of ``t``."""


def sample_ghost_chain(cfg: GhostChainConfig, rng: np.random.Generator) -> GhostChain:
    """Draw a ghost chain from ``cfg``'s ranges: evenly spaced (``regular_prob``) or
    uniform positions ``t``, one shape, independent sizes, tints and edges."""
    n = int(rng.integers(cfg.count[0], cfg.count[1] + 1))
    lo, hi = cfg.t
    if n > 1 and rng.random() < cfg.regular_prob:
        step = min(_uniform(rng, cfg.spacing), (hi - lo) / (n - 1))
        ts = rng.uniform(lo, hi - step * (n - 1)) + step * np.arange(n)
    else:
        ts = np.sort(rng.uniform(lo, hi, n))
    ghosts = []
    for t in ts:
        hue_lo, hue_hi = cfg.hues[int(rng.integers(len(cfg.hues)))]
        ghosts.append(Ghost(
            t=float(t), radius=_loguniform(rng, cfg.radius),
            amplitude=_loguniform(rng, cfg.amplitude),
            tint=hsv_rgb(rng.uniform(hue_lo, hue_hi), _uniform(rng, cfg.saturation)),
            ring=bool(rng.random() < cfg.ring_prob), softness=_loguniform(rng, cfg.softness),
            chroma=_uniform(rng, cfg.chroma)))
    return GhostChain(blades=int(rng.choice(cfg.sides)), rotation=float(rng.uniform(0, np.pi)),
                      ghosts=ghosts)


def render_ghost_chain(p: GhostChain, light_xy: tuple[float, float],
                       center_xy: tuple[float, float], size_hw: tuple[int, int],
                       rgb: np.ndarray, rng: np.random.Generator | None = None,
                       flicker: float = 0.0) -> np.ndarray:
    """[H, W, 3] the ghosts at ``c + t (light - c)`` (``c`` = ``center_xy``); with ``rng``,
    each ghost's amplitude flickers (log-normal sigma ``flicker``)."""
    H, W = size_hw
    diag = float(np.hypot(H, W))
    out = np.zeros((H, W, 3), np.float32)
    (lx, ly), (cx, cy) = light_xy, center_xy
    for g in p.ghosts:
        gx, gy = cx + g.t * (lx - cx), cy + g.t * (ly - cy)
        amp = g.amplitude
        if rng is not None and flicker > 0:
            amp *= float(np.exp(rng.normal(0, flicker)))
        patch = _ghost_patch(g, g.radius * diag, p.blades, p.rotation)
        half = patch.shape[0] // 2
        _paste(out, patch * (amp * rgb).astype(np.float32), int(round(gx)) - half,
               int(round(gy)) - half)
    return out


@dataclass
class Streak:
    """One streak through the light (see :class:`StreakConfig`)."""

    angle: float
    """Direction (radians; 0 = horizontal)."""
    length: float
    """Fall-off length ``L``, fraction of the diagonal."""
    width: float
    """Gaussian sigma ``w`` across it at the light, fraction of the diagonal."""
    spread: float
    """Widening with distance: sigma ``w (1 + spread |s| / L)``."""
    amplitude: float
    """Linear value at the light at intensity 1."""
    tint: np.ndarray
    """[3] linear RGB tint (max 1)."""


@dataclass
class Streaks:
    """One lens's streaks (kind ``streaks``)."""

    anamorphic: bool
    """One thin horizontal (anamorphic) streak, else smeared streaks."""
    streaks: list[Streak]


STREAK_FLOOR = 1e-5
"""Linear value below which a streak's tail is not drawn (far under any mask threshold)."""


def sample_streaks(cfg: StreakConfig, rng: np.random.Generator) -> Streaks:
    """Draw streaks from ``cfg``'s ranges: anamorphic (``anamorphic_prob``) or smeared."""
    if rng.random() < cfg.anamorphic_prob:
        tilt = np.deg2rad(rng.uniform(-cfg.anamorphic_tilt, cfg.anamorphic_tilt))
        return Streaks(anamorphic=True, streaks=[Streak(
            angle=float(tilt), length=_loguniform(rng, cfg.anamorphic_length),
            width=_loguniform(rng, cfg.anamorphic_width), spread=0.1 * _uniform(rng, cfg.spread),
            amplitude=_loguniform(rng, cfg.amplitude),
            tint=hsv_rgb(_uniform(rng, cfg.anamorphic_hues),
                         _uniform(rng, cfg.anamorphic_saturation)))])
    streaks: list[Streak] = []
    for i in range(int(rng.integers(cfg.count[0], cfg.count[1] + 1))):
        amp = (_loguniform(rng, cfg.amplitude) if i == 0
               else streaks[0].amplitude * rng.uniform(0.3, 1.0))
        streaks.append(Streak(
            angle=float(rng.uniform(0, np.pi)), length=_loguniform(rng, cfg.length),
            width=_loguniform(rng, cfg.width), spread=_uniform(rng, cfg.spread),
            amplitude=float(amp), tint=hsv_rgb(rng.uniform(0, 360), _uniform(rng, cfg.saturation))))
    return Streaks(anamorphic=False, streaks=streaks)


def render_streaks(p: Streaks, light_xy: tuple[float, float], size_hw: tuple[int, int],
                   rgb: np.ndarray) -> np.ndarray:
    """[H, W, 3] straight streaks through the light, both ways: along (distance ``s``)
    ``a (0.7 exp(-|s| / L) + 0.3 exp(-|s| / 0.1 L))``, across Gaussian with sigma
    ``w (1 + spread |s| / L)``; drawn until the value falls below ``STREAK_FLOOR``."""
    H, W = size_hw
    diag = float(np.hypot(H, W))
    out = np.zeros((H, W, 3), np.float32)
    for st in p.streaks:
        colour = (st.amplitude * np.asarray(st.tint) * rgb).astype(np.float32)
        L, w0 = max(st.length * diag, 1.0), max(st.width * diag, 0.6)
        reach = L * float(np.log(max(0.7 * float(colour.max()) / STREAK_FLOOR, 1.0)))
        if reach <= 0:
            continue
        half = 4 * w0 * (1 + st.spread * reach / L)
        ys, xs = _line_band(light_xy, st.angle, (-reach, reach), half, size_hw)
        if len(ys) == 0:
            continue
        s, d = _along_across(ys, xs, light_xy, st.angle)
        s = np.abs(s)
        w = np.float32(w0) * (1 + np.float32(st.spread / L) * s)
        along = 0.7 * np.exp(-s / np.float32(L)) + 0.3 * np.exp(-s / np.float32(0.1 * L))
        val = along * np.exp(-0.5 * (d / w) ** 2)
        out[ys, xs] += val[:, None] * colour
    return out


@dataclass
class VeilingGlare:
    """One lens's veiling glare (kind ``glare``; see :class:`VeilingGlareConfig`)."""

    glow_amplitude: float
    """Peak linear value of the glow at intensity 1."""
    glow_width: float
    """Half-width of the glow, fraction of the diagonal."""
    veil_level: float
    """Peak luminance of the veil at intensity 1, fraction of the absolute mask threshold."""
    veil_width: float
    """Half-width of the veil, fraction of the diagonal."""
    cast_level: float
    """Luminance of the uniform colour cast at intensity 1, fraction of the threshold."""
    tint: np.ndarray
    """[3] linear RGB tint of veil and cast (max 1); the glow's is half as saturated."""


def sample_veiling_glare(cfg: VeilingGlareConfig, rng: np.random.Generator) -> VeilingGlare:
    """Draw a veiling glare from ``cfg``'s ranges."""
    return VeilingGlare(
        glow_amplitude=_loguniform(rng, cfg.glow_amplitude),
        glow_width=_uniform(rng, cfg.glow_width), veil_level=_uniform(rng, cfg.veil_level),
        veil_width=_uniform(rng, cfg.veil_width), cast_level=_uniform(rng, cfg.cast_level),
        tint=hsv_rgb(rng.uniform(0, 360), _uniform(rng, cfg.saturation)))


def render_veiling_glare(p: VeilingGlare, light_xy: tuple[float, float],
                         size_hw: tuple[int, int], rgb: np.ndarray,
                         threshold: float) -> np.ndarray:
    """[H, W, 3] glow ``(1 + (d / w)^2)^-2`` + veil ``(1 + (d / W)^2)^-1`` + uniform cast.

    Veil and cast are set in units of the absolute mask ``threshold`` (luminance) and scaled
    down together where needed so that their sum stays below ``VEIL_CAP x threshold``: they
    lift a large area a little and never enter the mask on their own.
    """
    H, W = size_hw
    diag = float(np.hypot(H, W))
    tint = np.asarray(p.tint, np.float32)
    unit = tint * rgb / float(LUMA @ tint)  # luminance ~ that of rgb
    veil_rgb = p.veil_level * threshold * unit
    cast_rgb = p.cast_level * threshold * unit
    lum = float(LUMA @ (veil_rgb + cast_rgb))
    if lum > VEIL_CAP * threshold:
        scale = VEIL_CAP * threshold / lum
        veil_rgb, cast_rgb = veil_rgb * scale, cast_rgb * scale
    glow_rgb = p.glow_amplitude * (0.5 + 0.5 * tint) * rgb
    x2 = ((np.arange(W, dtype=np.float32) - np.float32(light_xy[0])) / np.float32(diag)) ** 2
    y2 = ((np.arange(H, dtype=np.float32) - np.float32(light_xy[1])) / np.float32(diag)) ** 2
    q = y2[:, None] + x2[None, :]  # (d / diagonal)^2
    g = 1 / (1 + q / np.float32(p.glow_width ** 2))
    veil = 1 / (1 + q / np.float32(p.veil_width ** 2))
    out = cv2.transform((g * g)[..., None], glow_rgb.astype(np.float32)[:, None])
    out += cv2.transform(veil[..., None], veil_rgb.astype(np.float32)[:, None])
    out += cast_rgb.astype(np.float32)
    return out


_SAMPLERS = {"starburst": sample_starburst, "ghosts": sample_ghost_chain,
             "streaks": sample_streaks, "glare": sample_veiling_glare}
"""Kind -> the sampler of its parameters from ``getattr(FlareConfig, kind)``."""


def mask_threshold(cfg: FlareConfig, size_hw: tuple[int, int],
                   background_linear: np.ndarray | None = None) -> np.float32 | np.ndarray:
    """The mask rule's threshold on the flare's linear luminance: ``cfg.mask_abs_threshold``
    (default ``MASK_THRESHOLD``) alone, or with a background [H, W, 3] (linear light) the
    per-pixel [H, W] ``max(abs, mask_rel_threshold x background luminance)``, the background
    luminance first smoothed (Gaussian, ``mask_smooth`` x diagonal) so masks follow regions,
    not texture."""
    thr = np.float32(cfg.mask_abs_threshold)
    if background_linear is not None:
        bg = _smooth(luminance(background_linear), cfg.mask_smooth * float(np.hypot(*size_hw)))
        thr = np.maximum(thr, np.float32(cfg.mask_rel_threshold) * bg)
    return thr


def flare_mask(flare: np.ndarray, core: np.ndarray, cfg: FlareConfig,
               background_linear: np.ndarray | None = None) -> np.ndarray:
    """[H, W] bool: linear flare luminance > :func:`mask_threshold`, minus the core
    (wherever ``core`` is non-zero). ``flare`` is all the added flare, every kind summed."""
    thr = mask_threshold(cfg, flare.shape[:2], background_linear)
    core_any = cv2.transform(np.ascontiguousarray(core), np.ones((1, 3), np.float32)) > 0
    return (luminance(flare) > thr) & ~core_any.reshape(core.shape[:2])


def _smooth(x: np.ndarray, sigma: float) -> np.ndarray:
    """[H, W] Gaussian blur with ``sigma`` pixels, done at reduced resolution when wide."""
    if sigma <= 0.3:
        return x
    f = max(int(sigma // 2), 1)
    H, W = x.shape
    if f == 1 or min(H, W) < 8 * f:
        return cv2.GaussianBlur(x, (0, 0), sigma)
    small = cv2.resize(x, (W // f, H // f), interpolation=cv2.INTER_AREA)
    small = cv2.GaussianBlur(small, (0, 0), sigma / f)
    return cv2.resize(small, (W, H), interpolation=cv2.INTER_LINEAR)


def render_flare(lens: Lens, light_xy: tuple[float, float], size_hw: tuple[int, int],
                 rng: np.random.Generator | None = None, intensity: float | None = None,
                 background_linear: np.ndarray | None = None,
                 center_xy: tuple[float, float] | None = None) -> FlareLayers:
    """Render ``lens`` for a point light at pixel ``light_xy`` (may be outside the frame).

    Every kind of ``lens.kinds`` (:func:`render_kind`) is added up into ``flare``; the mask
    is :func:`flare_mask` of that sum. ``intensity`` scales every kind (default 1; the core
    is the light itself and stays saturated). ``background_linear`` [H, W, 3] (the clean
    photo in linear light) only sets the mask's relative threshold. ``center_xy`` is the
    optical centre (default the image centre; pass the principal point). ``rng`` draws the
    per-render ghost flicker (``cfg.ghost_flicker``); None means no flicker.
    """
    H, W = size_hw
    k = 1.0 if intensity is None else float(intensity)
    lx, ly = float(light_xy[0]), float(light_xy[1])
    cx, cy = ((W - 1) / 2, (H - 1) / 2) if center_xy is None else center_xy
    flare, ghost_xy = None, []
    for kind in lens.kinds:
        if kind == "scatter":
            layer, ghost_xy = _render_lens_scatter(lens, (lx, ly), size_hw, k, (cx, cy), rng)
        else:
            layer = render_kind(lens, kind, (lx, ly), size_hw, rng, k, (cx, cy))
        flare = layer if flare is None else flare + layer
    if flare is None:
        flare = np.zeros((H, W, 3), np.float32)
    core = _render_core(lens, (lx, ly), size_hw, float(np.hypot(H, W)))
    mask = flare_mask(flare, core, lens.cfg, background_linear)
    return FlareLayers(flare=flare, core=core, mask=mask, light_xy=(lx, ly), ghost_xy=ghost_xy,
                       kinds=tuple(lens.kinds))


def render_kind(lens: Lens, kind: str, light_xy: tuple[float, float],
                size_hw: tuple[int, int], rng: np.random.Generator | None = None,
                intensity: float | None = None,
                center_xy: tuple[float, float] | None = None) -> np.ndarray:
    """[H, W, 3] float32: the linear light one kind of ``lens`` adds (arguments as in
    :func:`render_flare`; ``kind`` must be one of ``lens.kinds``)."""
    H, W = size_hw
    k = 1.0 if intensity is None else float(intensity)
    light = (float(light_xy[0]), float(light_xy[1]))
    centre = ((W - 1) / 2, (H - 1) / 2) if center_xy is None else center_xy
    if kind == "scatter":
        return _render_lens_scatter(lens, light, size_hw, k, centre, rng)[0]
    p = lens.kind_params[kind]
    rgb = (k * np.asarray(lens.light_rgb, np.float32)).astype(np.float32)
    if kind == "starburst":
        return render_starburst(p, light, size_hw, rgb)
    if kind == "ghosts":
        return render_ghost_chain(p, light, centre, size_hw, rgb, rng, lens.cfg.ghost_flicker)
    if kind == "streaks":
        return render_streaks(p, light, size_hw, rgb)
    if kind == "glare":
        return render_veiling_glare(p, light, size_hw, rgb, lens.cfg.mask_abs_threshold)
    raise ValueError(f"unknown flare kind {kind!r}")


def _render_lens_scatter(lens: Lens, light_xy: tuple[float, float], size_hw: tuple[int, int],
                         k: float, center_xy: tuple[float, float],
                         rng: np.random.Generator | None
                         ) -> tuple[np.ndarray, list[tuple[float, float]]]:
    """The ``scatter`` kind: ([H, W, 3] PSF scatter + the lens's ghosts + its halo, the
    ghosts' centres), exactly as the synthesizer rendered before kinds existed."""
    diag = float(np.hypot(*size_hw))
    (lx, ly), (cx, cy) = light_xy, center_xy
    flare = _render_scatter(lens, (lx, ly), size_hw, diag)  # [H, W, 3]
    flare = cv2.multiply(flare, _scalar(lens.light_rgb * (k * lens.scatter_flux)))
    glare_rgb = k * lens.glare_amplitude * lens.glare_tint * lens.light_rgb  # [3]
    glare = _render_glare(lens, (lx, ly), size_hw, diag)  # [H, W]
    flare += cv2.transform(glare[..., None], glare_rgb.astype(np.float32)[:, None])
    ghost_xy = []
    for g in lens.ghosts:
        gx, gy = cx + g.t * (lx - cx), cy + g.t * (ly - cy)
        ghost_xy.append((gx, gy))
        amp = g.amplitude * k
        if rng is not None and lens.cfg.ghost_flicker > 0:
            amp *= float(np.exp(rng.normal(0, lens.cfg.ghost_flicker)))
        radius = g.radius * diag * (0.35 + abs(g.t))
        patch = _ghost_patch(g, radius, lens.blades, lens.blade_rotation)
        half = patch.shape[0] // 2
        _paste(flare, patch * (amp * lens.light_rgb), int(round(gx)) - half,
               int(round(gy)) - half)
    return flare, ghost_xy


# --------------------------------------------------------------------------- compositing
def apply_flare(image_srgb: np.ndarray, layers: FlareLayers,
                rng: np.random.Generator | None = None, noise: float = 0.0,
                gain: float = 1.0) -> np.ndarray:
    """Composite flare onto a photo: ``srgb(clip(gain * (linear(photo) + flare + core) +
    noise))``.

    ``image_srgb`` [H, W, 3] uint8 (0-255) or float in [0, 1]; returns float32 sRGB in
    [0, 1] whatever the input dtype (callers quantise). ``noise`` is the std of Gaussian
    noise in linear light (needs ``rng``).
    """
    return _composite(image_to_linear(image_srgb), layers, rng, noise, gain)


def _composite(linear: np.ndarray, layers: FlareLayers, rng: np.random.Generator | None,
               noise: float, gain: float) -> np.ndarray:
    out = linear + layers.flare
    out += layers.core
    if gain != 1.0:
        out *= np.float32(gain)
    if noise > 0:
        if rng is None:
            raise ValueError("apply_flare: noise > 0 needs an rng")
        cv2.setRNGSeed(int(rng.integers(2 ** 31)))  # OpenCV's Gaussian RNG is ~3x faster
        n = np.empty_like(out)
        cv2.randn(n, 0.0, float(noise))
        out += n
    return linear_to_srgb(out)


def sample_light_xy(cfg: FlareConfig, size_hw: tuple[int, int],
                    rng: np.random.Generator) -> tuple[float, float]:
    """A light position: uniform in the frame, or (``light_outside_prob``) just outside it."""
    H, W = size_hw
    if rng.random() < cfg.light_outside_prob:
        m = cfg.light_outside_margin * float(np.hypot(H, W))
        while True:
            x, y = rng.uniform(-m, W + m), rng.uniform(-m, H + m)
            if not (0 <= x < W and 0 <= y < H):
                return float(x), float(y)
    return float(rng.uniform(0, W)), float(rng.uniform(0, H))


def synthesize(image_srgb: np.ndarray, cfg: FlareConfig, rng: np.random.Generator,
               light_xy: tuple[float, float] | None = None
               ) -> tuple[np.ndarray, FlareLayers]:
    """One training composite: a fresh lens, light, intensity, gain and noise from ``cfg``.

    ``image_srgb`` [H, W, 3] uint8 or float in [0, 1]. Returns (flared sRGB float32 [H, W, 3]
    in [0, 1], the layers). The mask's threshold is relative to the photo's brightness.
    """
    linear = image_to_linear(image_srgb)
    H, W = linear.shape[:2]
    lens = sample_lens(cfg, rng)
    if light_xy is None:
        light_xy = sample_light_xy(cfg, (H, W), rng)
    k = _loguniform(rng, cfg.intensity)
    gain = _uniform(rng, cfg.gain)
    noise = _uniform(rng, cfg.noise)
    layers = render_flare(lens, light_xy, (H, W), rng, k, linear)
    return _composite(linear, layers, rng, noise, gain), layers
