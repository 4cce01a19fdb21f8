"""Physically based lens-flare synthesis (after Wu et al., ICCV 2021).

A bright point light seen through a real lens leaves four things on the sensor; this
module renders each of them in LINEAR light and adds them to a clean photo.

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
3. **Glare / veiling haze**: a broad, low-frequency falloff ``(1 + (d / w)^2)^-1.5`` around
   the light.
4. **The light source core**: a small saturated disc (the light itself, not flare).

The layers are kept apart (:class:`FlareLayers`): ``flare`` (1-3), ``core`` (4) and a
ground-truth flare-occupancy ``mask``. Compositing (:func:`apply_flare`) converts the photo
from sRGB to linear, adds ``flare + core``, applies gain and noise, clips and converts
back. The mask marks where the flare is visible: linear flare luminance above
``max(mask_abs_threshold, mask_rel_threshold * background luminance)``, with the core disc
excluded (the light source itself is not flare). The background luminance is smoothed
(``mask_smooth``) first so that masks follow regions rather than texture.

PSFs are the only costly part (hundreds of FFTs), so a bank of ``n_psfs`` RGB PSFs is built
once per bank configuration and cached in memory and on disk
(``$DEFLARE_CACHE`` or ``~/.cache/deflare-scene``, ``psf_bank_<hash>.npz``). A lens
(:class:`Lens`, sampled once per scene) picks one PSF of the bank, a rotation and a scale,
its ghost layout and tints; rendering a lens at a light position is then a few warps and
small patch draws. Everything is deterministic given the random generator (the
compositing noise seeds OpenCV's generator from it).

Typical use (a training composite; about 30 ms CPU at 512x512, 50 ms at 1008x756)::

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
import os
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

LAMBDA0 = 550.0  # nm, reference wavelength of the PSF grid
LUMA = np.array([0.2126, 0.7152, 0.0722], np.float32)  # linear-light luminance weights


# --------------------------------------------------------------------------- colour
def _pow(x: np.ndarray, p: float) -> np.ndarray:
    """``x ** p`` for x > 0 (float32, any shape) via OpenCV's fast exp/log."""
    flat = np.maximum(x, np.float32(1e-12)).reshape(-1, 1)
    return cv2.exp(cv2.log(flat) * np.float32(p)).reshape(x.shape)


def srgb_to_linear(x: np.ndarray) -> np.ndarray:
    """sRGB-encoded values in [0, 1] to linear light (IEC 61966-2-1), float32."""
    x = np.clip(np.asarray(x, np.float32), 0.0, 1.0)
    hi = _pow((x + np.float32(0.055)) * np.float32(1 / 1.055), 2.4)
    return np.where(x <= 0.04045, x * np.float32(1 / 12.92), hi)


def linear_to_srgb(x: np.ndarray) -> np.ndarray:
    """Linear light in [0, 1] (clipped) to sRGB encoding, float32."""
    x = np.clip(np.asarray(x, np.float32), 0.0, 1.0)
    hi = np.float32(1.055) * _pow(x, 1 / 2.4) - np.float32(0.055)
    return np.where(x <= 0.0031308, x * np.float32(12.92), hi)


_SRGB8_TO_LINEAR = None


def image_to_linear(image: np.ndarray) -> np.ndarray:
    """[H, W, 3] uint8 (0-255, a table lookup) or float sRGB in [0, 1] -> float32 linear."""
    global _SRGB8_TO_LINEAR
    image = np.asarray(image)
    if image.dtype == np.uint8:
        if _SRGB8_TO_LINEAR is None:
            _SRGB8_TO_LINEAR = srgb_to_linear(np.arange(256, dtype=np.float32) / 255)
        return cv2.LUT(image, _SRGB8_TO_LINEAR)
    return srgb_to_linear(image)


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
class FlareConfig:
    """Ranges from which lenses, lights and flares are drawn. ``(lo, hi)`` pairs are uniform
    unless noted log-uniform. Sizes are fractions of the image diagonal unless noted."""

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
    """Log-uniform. Multiplier of the lens's flare (scatter, ghosts, glare)."""
    light_outside_prob: float = 0.15
    """Probability that synthesize puts the light outside the frame (flare still enters)."""
    light_outside_margin: float = 0.25
    """How far outside the frame such a light can be."""
    noise: tuple[float, float] = (0.0, 0.004)
    """Std of Gaussian noise added in linear light."""
    gain: tuple[float, float] = (0.85, 1.15)
    """Exposure gain applied in linear light before clipping."""

    # ground-truth mask
    mask_abs_threshold: float = 0.012
    """Flare is visible where its linear luminance exceeds this ..."""
    mask_rel_threshold: float = 0.1
    """... and this fraction of the background's linear luminance (both must hold)."""
    mask_smooth: float = 0.004
    """Gaussian sigma (fraction of the diagonal) smoothing the background luminance used by
    the relative threshold."""

    @classmethod
    def unseen(cls) -> FlareConfig:
        """Settings the default config never draws (out-of-distribution FMG evaluation):
        pentagon/heptagon/nonagon apertures, more ghosts, red/orange/blue ghost tints,
        more scratches and stronger defocus; a different bank seed."""
        return cls(aperture_blades=(5, 7, 9), ghost_count=(9, 13),
                   ghost_hues=((0.0, 60.0), (205.0, 255.0)), scratch_count=(11, 18),
                   defocus_waves=(0.9, 1.5), bank_seed=1)

    def bank_fields(self) -> dict:
        names = ("psf_size", "n_psfs", "n_wavelengths", "aperture_radius", "aperture_blades",
                 "dust_count", "dust_radius", "scratch_count", "scratch_width",
                 "defocus_waves", "bank_seed")
        return {n: getattr(self, n) for n in names}

    def bank_key(self) -> str:
        text = json.dumps({"v": 1, **self.bank_fields()}, sort_keys=True)
        return hashlib.blake2b(text.encode(), digest_size=8).hexdigest()


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

    def summary(self) -> dict:
        """JSON-serialisable description."""
        d = {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name != "cfg"}
        d["ghosts"] = [dataclasses.asdict(g) for g in self.ghosts]
        d["bank"] = self.cfg.bank_key()
        return json.loads(json.dumps(d, default=lambda v: np.asarray(v).tolist()))


def sample_lens(cfg: FlareConfig, rng: np.random.Generator) -> Lens:
    """Draw one lens from ``cfg``'s ranges."""
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
    """[H, W, 3] float32: scatter + ghosts + glare, the core excluded."""
    core: np.ndarray
    """[H, W, 3] float32: the light source itself."""
    mask: np.ndarray
    """[H, W] bool: ground-truth flare occupancy (visible flare, core excluded)."""
    light_xy: tuple[float, float] = (0.0, 0.0)
    """Light position in pixels (x right, y down; may be outside the frame)."""
    ghost_xy: list[tuple[float, float]] = field(default_factory=list)
    """Centres of the ghosts in pixels, in ``lens.ghosts`` order."""


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


def flare_mask(flare: np.ndarray, core: np.ndarray, cfg: FlareConfig,
               background_linear: np.ndarray | None = None) -> np.ndarray:
    """[H, W] bool: linear flare luminance > max(abs, rel x background luminance), minus the
    core (wherever ``core`` is non-zero). The background luminance is first smoothed
    (Gaussian, ``mask_smooth`` x diagonal) so masks follow regions, not texture."""
    thr = np.float32(cfg.mask_abs_threshold)
    if background_linear is not None:
        bg = _smooth(luminance(background_linear),
                     cfg.mask_smooth * float(np.hypot(*flare.shape[:2])))
        thr = np.maximum(thr, np.float32(cfg.mask_rel_threshold) * bg)
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

    ``intensity`` scales scatter, ghosts and glare (default 1; the core is the light itself
    and stays saturated). ``background_linear`` [H, W, 3] (the clean photo in linear light)
    only sets the mask's relative threshold. ``center_xy`` is the optical centre (default the
    image centre; pass the principal point). ``rng`` draws the per-render ghost flicker
    (``cfg.ghost_flicker``); None means no flicker.
    """
    H, W = size_hw
    diag = float(np.hypot(H, W))
    k = 1.0 if intensity is None else float(intensity)
    lx, ly = float(light_xy[0]), float(light_xy[1])
    cx, cy = ((W - 1) / 2, (H - 1) / 2) if center_xy is None else center_xy
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
    core = _render_core(lens, (lx, ly), size_hw, diag)
    mask = flare_mask(flare, core, lens.cfg, background_linear)
    return FlareLayers(flare=flare, core=core, mask=mask, light_xy=(lx, ly), ghost_xy=ghost_xy)


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
