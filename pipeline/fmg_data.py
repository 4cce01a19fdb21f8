"""FMG training data: synthetic flare composited onto real photos, with its mask.

Following the paper (and Flare7K), each composite takes a flare pattern, moves it by a random
affine transform (rotation, scale, translation, shear) and adds it to a photo; the same
transform is applied to the pattern's mask. Here the pattern comes from the physically
based synthesizer (``pipeline/flare.py``): a fresh lens, light position and intensity per
composite. The warped mask is then also cut where the flare is not visible against the new
background (the synthesizer's relative threshold), and the light core is never flare.

Backgrounds are every image under ``<data>/backgrounds`` and ``<data>/scenes`` (found
recursively), downscaled once into memory. Validation keeps whole scenes out
(``pipeline.datasets.HELDOUT_SCENES``) plus a few held-out backgrounds. Training adds random
crops, flips, colour jitter, composites without flare, and sharp-edged bright shapes that
are not flare (the scenes bring their own sky and white walls), so the network learns to
leave bright non-flare content and the light itself unmarked.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from pipeline import flare as fl
from pipeline.datasets import HELDOUT_SCENES, IMAGE_EXTENSIONS
from pipeline.errors import UserError

HELDOUT_BACKGROUNDS: tuple[str, ...] = ("coffee", "rocket", "grace_hopper")
"""Stems of background photos kept out of FMG training (validation only)."""


@dataclass
class CompositeConfig:
    """How composites are drawn."""

    size: int = 256
    """Side of the square composite (pixels)."""
    preload_side: int = 512
    """Long side to which every background is downscaled once, in memory."""
    crop_scale: tuple[float, float] = (0.45, 1.0)
    """Crop side as a fraction of the background's short side (then resized to ``size``)."""
    flare_prob: float = 0.85
    """Probability that a training composite has flare (the rest teach 'nothing here')."""
    distractor_prob: float = 0.3
    """Probability of adding sharp-edged bright non-flare shapes to a training composite."""
    rotation: tuple[float, float] = (-180.0, 180.0)
    """Affine rotation of the flare layer (degrees)."""
    scale: tuple[float, float] = (0.7, 1.4)
    """Affine scale of the flare layer."""
    translate: float = 0.25
    """Affine translation, up to this fraction of ``size`` in x and y."""
    shear: tuple[float, float] = (-20.0, 20.0)
    """Affine shear (degrees)."""
    jitter: float = 0.2
    """Strength of brightness / contrast / saturation jitter of the background."""
    night_prob: float = 0.0
    """Probability of darkening the background to dusk / night (linear light x
    ``night_gain``, slightly blue), as in real flare photos taken at night."""
    night_gain: tuple[float, float] = (0.02, 0.3)
    """Log-uniform linear-light gain of a night background."""
    streak_prob: float = 0.0
    """Probability that a flared composite also gets long straight streaks through the light
    (the broad diagonal scatter streaks of real phone / windscreen flare), labelled flare."""
    streak_amplitude: tuple[float, float] = (0.03, 0.6)
    """Log-uniform peak linear value of a streak at the light (x flare intensity)."""
    streak_length: tuple[float, float] = (0.1, 0.6)
    """Exponential fall-off length of a streak along its axis, fraction of the diagonal."""
    streak_width: tuple[float, float] = (0.004, 0.025)
    """Gaussian half-width of a streak at the light, fraction of the diagonal (it widens
    with distance)."""


# --------------------------------------------------------------------------- backgrounds
def find_images(root: Path) -> list[Path]:
    return sorted(p for p in root.rglob("*") if p.is_file()
                  and p.suffix.lower() in IMAGE_EXTENSIONS and not p.name.startswith("."))


def split_backgrounds(data: Path) -> tuple[list[Path], list[Path]]:
    """(train, validation) image paths under ``data``/backgrounds and ``data``/scenes."""
    bg, sc = data / "backgrounds", data / "scenes"
    if not bg.is_dir() and not sc.is_dir():
        raise UserError(f"{data} has neither backgrounds/ nor scenes/: pass --data pointing "
                        "at a folder with photos in backgrounds/ and/or scenes/<scene>/")
    train, val = [], []
    for p in (find_images(bg) if bg.is_dir() else []):
        (val if p.stem in HELDOUT_BACKGROUNDS else train).append(p)
    for p in (find_images(sc) if sc.is_dir() else []):
        scene = p.relative_to(sc).parts[0]
        (val if scene in HELDOUT_SCENES else train).append(p)
    return train, val


def load_backgrounds(paths: list[Path], long_side: int) -> list[np.ndarray]:
    """RGB uint8 images, downscaled so their long side is at most ``long_side``."""
    out = []
    for p in paths:
        img = cv2.imread(str(p), cv2.IMREAD_COLOR)
        if img is None:
            continue
        s = long_side / max(img.shape[:2])
        if s < 1:
            img = cv2.resize(img, None, fx=s, fy=s, interpolation=cv2.INTER_AREA)
        out.append(np.ascontiguousarray(img[..., ::-1]))
    return out


# --------------------------------------------------------------------------- augmentation
def random_crop(img: np.ndarray, size: int, scale: tuple[float, float],
                rng: np.random.Generator) -> np.ndarray:
    """A random square crop resized to ``size``, randomly flipped; float32 sRGB [0, 1]."""
    h, w = img.shape[:2]
    side = max(8, int(min(h, w) * rng.uniform(*scale)))
    y, x = int(rng.integers(0, h - side + 1)), int(rng.integers(0, w - side + 1))
    crop = cv2.resize(img[y:y + side, x:x + side], (size, size), interpolation=cv2.INTER_AREA)
    if rng.random() < 0.5:
        crop = crop[:, ::-1]
    return np.ascontiguousarray(crop, np.float32) / 255.0


def colour_jitter(img: np.ndarray, strength: float, rng: np.random.Generator) -> np.ndarray:
    """Brightness, contrast and saturation jitter of a float sRGB image [H, W, 3]."""
    b, c, s = 1 + strength * rng.uniform(-1, 1, 3)
    grey = img.mean(axis=2, keepdims=True)
    img = grey + s * (img - grey)
    img = img.mean() + c * (img - img.mean())
    return np.clip(img * b, 0, 1).astype(np.float32)


def add_distractors(img: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Paint 1-3 sharp-edged bright shapes (windows, lamps, white walls): not flare."""
    img = img.copy()
    size = img.shape[0]
    for _ in range(int(rng.integers(1, 4))):
        colour = np.clip(rng.uniform(0.85, 1.0) + rng.normal(0, 0.05, 3), 0, 1)
        c = tuple(float(v) for v in colour)
        p = rng.integers(0, size, 2)
        r = rng.integers(size // 20, size // 4, 2)
        if rng.random() < 0.5:
            cv2.rectangle(img, tuple(int(v) for v in p - r), tuple(int(v) for v in p + r), c,
                          -1, cv2.LINE_AA)
        else:
            cv2.ellipse(img, (int(p[0]), int(p[1])), (int(r[0]), int(r[1])),
                        float(rng.uniform(0, 180)), 0, 360, c, -1, cv2.LINE_AA)
    return img


def darken_night(img: np.ndarray, cfg: CompositeConfig,
                 rng: np.random.Generator) -> np.ndarray:
    """Dusk / night version of an sRGB float image [S, S, 3]: linear light x a small gain,
    with a random cool (blue) tint."""
    g = float(np.exp(rng.uniform(*np.log(cfg.night_gain))))
    tint = np.array([1.0 - rng.uniform(0, 0.3), 1.0 - rng.uniform(0, 0.15), 1.0], np.float32)
    return fl.linear_to_srgb(fl.srgb_to_linear(img) * np.float32(g) * tint).astype(np.float32)


def render_streaks(light_xy: tuple[float, float], size: int, rgb: np.ndarray,
                   cfg: CompositeConfig, rng: np.random.Generator) -> np.ndarray:
    """[S, S, 3] linear light: 1-2 long straight streaks through ``light_xy``, each
    ``a exp(-|s| / L) exp(-d^2 / 2 w(s)^2)`` with ``w(s) = w0 (1 + |s| / L)``, s along and d
    across the streak; ``rgb`` [3] is the light colour times the flare intensity."""
    diag = float(np.hypot(size, size))
    yy, xx = np.mgrid[0:size, 0:size].astype(np.float32)
    dx, dy = xx - np.float32(light_xy[0]), yy - np.float32(light_xy[1])
    out = np.zeros((size, size), np.float32)
    angle = rng.uniform(0, np.pi)
    for i in range(int(rng.integers(1, 3))):
        a = angle + (0 if i == 0 else rng.uniform(0.3, np.pi - 0.3))
        s = np.abs(dx * np.float32(np.cos(a)) + dy * np.float32(np.sin(a)))
        d = -dx * np.float32(np.sin(a)) + dy * np.float32(np.cos(a))
        length = rng.uniform(*cfg.streak_length) * diag
        w = rng.uniform(*cfg.streak_width) * diag * (1 + s / np.float32(length))
        amp = np.exp(rng.uniform(*np.log(cfg.streak_amplitude))) * (1 if i == 0 else 0.5)
        out += np.float32(amp) * np.exp(-s / np.float32(length) - 0.5 * (d / w) ** 2)
    return out[..., None] * rgb.astype(np.float32)


def random_affine(cfg: CompositeConfig, center: tuple[float, float],
                  rng: np.random.Generator) -> np.ndarray:
    """[2, 3] rotation x scale x shear about ``center``, then a translation."""
    a = np.deg2rad(rng.uniform(*cfg.rotation))
    sh = np.tan(np.deg2rad(rng.uniform(*cfg.shear)))
    s = rng.uniform(*cfg.scale)
    lin = s * np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]]) @ np.array(
        [[1.0, sh], [0.0, 1.0]])
    c = np.asarray(center, float)
    t = c - lin @ c + rng.uniform(-1, 1, 2) * cfg.translate * cfg.size
    return np.hstack([lin, t[:, None]]).astype(np.float32)


def warp_layers(layers: fl.FlareLayers, m: np.ndarray, size: int) -> fl.FlareLayers:
    """Apply one [2, 3] affine to the flare, the core and the mask alike."""
    def warp(x: np.ndarray, flags: int) -> np.ndarray:
        return cv2.warpAffine(x, m, (size, size), flags=flags,
                              borderMode=cv2.BORDER_CONSTANT, borderValue=0)

    return dataclasses.replace(
        layers, flare=warp(layers.flare, cv2.INTER_LINEAR),
        core=warp(layers.core, cv2.INTER_LINEAR),
        mask=warp(layers.mask.astype(np.uint8), cv2.INTER_NEAREST) > 0)


def composite_flare(img: np.ndarray, flare_cfg: fl.FlareConfig, comp: CompositeConfig,
                    rng: np.random.Generator, streaks: bool = True
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Flare an sRGB float image [S, S, 3]: (flared sRGB [S, S, 3] float32, mask [S, S] bool).

    A fresh lens at a random light position, its layers moved by one random affine; with
    probability ``comp.streak_prob`` (when ``streaks``) long streaks are added through the
    moved light. The mask is kept where the flare is visible against this background.
    """
    S = img.shape[0]
    lens = fl.sample_lens(flare_cfg, rng)
    light = fl.sample_light_xy(flare_cfg, (S, S), rng)
    k = float(np.exp(rng.uniform(*np.log(flare_cfg.intensity))))
    layers = fl.render_flare(lens, light, (S, S), rng, k)
    m = random_affine(comp, light, rng)
    layers = warp_layers(layers, m, S)
    label = layers.mask
    if streaks and rng.random() < comp.streak_prob:
        xy = m @ np.array([light[0], light[1], 1.0], np.float32)
        streak = render_streaks((float(xy[0]), float(xy[1])), S, lens.light_rgb * k, comp, rng)
        label = label | (fl.luminance(streak) > flare_cfg.mask_abs_threshold)
        layers = dataclasses.replace(layers, flare=layers.flare + streak)
    gain = float(rng.uniform(*flare_cfg.gain))
    noise = float(rng.uniform(*flare_cfg.noise))
    visible = fl.flare_mask(layers.flare, layers.core, flare_cfg,
                            fl.srgb_to_linear(img) * gain)
    layers = dataclasses.replace(layers, mask=label & visible)
    return fl.apply_flare(img, layers, rng, noise, gain), layers.mask


class CompositeSource:
    """Draws (image [S, S, 3] float32 sRGB, mask [S, S] bool) composites from backgrounds."""

    def __init__(self, backgrounds: list[np.ndarray], flare_cfg: fl.FlareConfig | None = None,
                 comp: CompositeConfig | None = None):
        if not backgrounds:
            raise UserError("no background photos found for FMG composites")
        self.backgrounds = backgrounds
        self.flare_cfg = flare_cfg or fl.FlareConfig()
        self.comp = comp or CompositeConfig()

    def sample(self, rng: np.random.Generator, train: bool = True,
               extras: bool | None = None) -> tuple[np.ndarray, np.ndarray]:
        """One composite. ``train`` adds jitter, distractors and flare-free samples;
        ``extras`` (default: ``train``) enables night backgrounds and streaks."""
        c = self.comp
        extras = train if extras is None else extras
        bg = self.backgrounds[int(rng.integers(len(self.backgrounds)))]
        img = random_crop(bg, c.size, c.crop_scale, rng)
        if extras and rng.random() < c.night_prob:
            img = darken_night(img, c, rng)
        if train:
            img = colour_jitter(img, c.jitter, rng)
            if rng.random() < c.distractor_prob:
                img = add_distractors(img, rng)
            if rng.random() >= c.flare_prob:
                return img, np.zeros(img.shape[:2], bool)
        return composite_flare(img, self.flare_cfg, c, rng, streaks=extras)

    def batch(self, n: int, rng: np.random.Generator, train: bool = True,
              extras: bool | None = None):
        """(images [n, 3, S, S] float32, masks [n, 1, S, S] float32) as torch tensors."""
        import torch

        pairs = [self.sample(rng, train, extras) for _ in range(n)]
        x = torch.from_numpy(np.stack([p[0] for p in pairs])).permute(0, 3, 1, 2)
        y = torch.from_numpy(np.stack([p[1] for p in pairs]))[:, None].float()
        return x.contiguous(), y


def fixed_set(source: CompositeSource, n: int, seed: int, extras: bool = False) -> tuple:
    """A deterministic validation set: n evaluation composites (every one flared); with
    ``extras``, night backgrounds and streaks as configured in ``source.comp``."""
    return source.batch(n, np.random.default_rng(seed), train=False, extras=extras)
