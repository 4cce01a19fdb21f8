"""The synthesizer's ranges (:class:`FlareConfig`) and the checks of kind names.

:class:`FlareConfig` holds the ``scatter`` kind's own fields, the light, compositing, the
mask rule, which kinds a lens combines, and each other kind's config; the checks read kind
names given on a command line."""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field, replace

from pipeline.errors import UserError
from pipeline.flare.common import KINDS, MASK_RELATIVE, MASK_THRESHOLD
from pipeline.flare.ghosts import GhostChainConfig
from pipeline.flare.glare import VeilingGlareConfig
from pipeline.flare.starburst import StarburstConfig
from pipeline.flare.streaks import StreakConfig


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
