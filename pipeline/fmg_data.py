"""FMG training data: synthetic flare composited onto real photos, with its mask.

Following the paper (and Flare7K), each composite takes a flare pattern, moves it by a random
affine transform (rotation, scale, translation, shear) and adds it to a photo; the same
transform is applied to the pattern's mask. Here the pattern comes from the physically
based synthesizer (``pipeline/flare/``): a fresh lens, light position and intensity per
composite, drawn from every kind of flare (``training_flare``: all of ``flare.KINDS``, or all
but the kinds left out for a leave-one-kind-out model). The warped mask is then also cut
where the flare is not visible against the new background (the synthesizer's relative
threshold), and the light core is never flare. With ``CompositeConfig.frame_prob`` a training
composite is instead a window of its photo at the photo's own scale, its flare rendered for the
whole photo about the photo's centre with no affine, as ``deflare-scene synth`` draws flare and
the mask stage meets it (:func:`frame_window`, :func:`draw_frame_flare`).

Backgrounds are every image under ``<data>/backgrounds`` and ``<data>/scenes`` (found
recursively), downscaled once into memory, in three parts (``split_backgrounds``): training;
development (``FMG_DEV_SCENES``: validation during training, every choice; photos no shipped
FMG has seen);
test (``HELDOUT_SCENES`` and ``HELDOUT_BACKGROUNDS``: reported only). Training adds random
crops, flips, colour jitter, night backgrounds, composites without flare, and **hard
negatives**: bright things that are not flare, painted onto the background before any flare
and labelled "no flare" (``add_hard_negatives``: lamps and their bare cores, specular
highlights, sky, white walls and windows, red / orange foliage, neon lines, reflections;
fair-weather clouds and foliage backlit at night on request), so the network learns to
leave bright non-flare content and the light itself unmarked.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import cv2
import numpy as np

from pipeline import flare as fl
from pipeline.colour import linear_to_srgb, srgb_to_linear
from pipeline.errors import UserError
from pipeline.images import list_photos, read_image
from pipeline.scene_splits import FMG_DEV_SCENES, HELDOUT_SCENES

HARD_NEGATIVES: tuple[str, ...] = ("lamp", "specular", "sky", "clouds", "wall", "foliage",
                                   "backlit", "neon", "reflection")
"""Kinds of bright non-flare content ``add_hard_negatives`` paints (see its docstring)."""

OPTIONAL_NEGATIVES: tuple[str, ...] = ("clouds", "backlit")
"""Kinds drawn only when `fmg train --negatives` names them: ``clouds``, since a 200-step check
did not show it lowering the marks on clean photos (docs/history/fmg.md, "Twenty-second
session"); ``backlit``, since its 200-step check failed its rule (twenty-fourth session)."""

DEFAULT_NEGATIVES: tuple[str, ...] = tuple(k for k in HARD_NEGATIVES
                                           if k not in OPTIONAL_NEGATIVES)
"""The kinds drawn unless asked otherwise (`fmg train --negatives`)."""

HELDOUT_BACKGROUNDS: tuple[str, ...] = ("coffee", "rocket", "grace_hopper")
"""Stems of background photos kept out of FMG training and choices: test composites only."""

REAL_FLARE_PHOTOS: tuple[str, ...] = ("sceaux_castle/100_7108", "sceaux_castle/100_7109")
"""Photos of the shared scenes (``<scene>/<stem>``) that hold real lens flare: rainbow ghosts
and veiling glare from the sun just out of frame (``docs/fmg_real_daylight_sceaux.jpg``).
Left out of every part: as a background their unmasked flare would be taught as no flare.
(The shipped FMG files were trained with them; the thirty-sixth session found them.)"""


@dataclass
class CompositeConfig:
    """How composites are drawn."""

    size: int = 256
    """Side of the square composite (pixels)."""
    preload_side: int = 512
    """Long side to which every background is downscaled once, in memory."""
    crop_scale: tuple[float, float] = (0.45, 1.0)
    """Crop side as a fraction of the background's short side (then resized to ``size``)."""
    flare_prob: float = 0.8
    """Probability that a training composite has flare (the rest teach 'nothing here')."""
    distractor_prob: float = 0.2
    """Probability of adding sharp-edged bright non-flare shapes to a training composite."""
    negative_prob: float = 0.5
    """Probability of hard negatives (``add_hard_negatives``) on a flared training composite."""
    clean_negative_prob: float = 0.8
    """Probability of hard negatives on a training composite without flare."""
    negatives: tuple[str, ...] = DEFAULT_NEGATIVES
    """Which kinds of hard negatives are drawn (of ``HARD_NEGATIVES``)."""
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
    night_glare: float = 1.0
    """The ``glare`` kind's probability on a night background is its ``FlareConfig``
    probability times this (capped at 1; 1: as by day, 0: no veiling glare at night). Trained
    on glare at night, a network marks a night sky's whole haze, the foliage beside a lamp
    included (candidate F26 on the real night photos, docs/history/fmg.md, "Seventy-ninth
    session"); fewer such composites are the card's next recipe (gnfr/weights/fmg.md)."""
    flare_canvas: float = 1.0
    """The flare is drawn for a frame this many times the composite's side, and the
    composite is a window of it around the light (1: drawn for the composite itself). The
    mask stage meets flare drawn across a whole photo at its working size (512 px), about
    twice the pixels of flare drawn for a 256 px composite; 2 draws it at that scale
    (docs/history/fmg.md, "Thirty-first session")."""
    frame_prob: float = 0.0
    """Probability that a training composite is cut from its photo as the mask stage meets
    it (:func:`frame_window`): a ``size`` window at the photo's own scale (``preload_side``,
    the mask stage's working size), its flare drawn for the whole photo with the optical
    centre at the photo's centre and no affine, as ``deflare-scene synth`` draws it. 0: every
    composite is a resized crop with its flare moved by the random affine."""


# --------------------------------------------------------------------------- backgrounds
def find_images(root: Path) -> list[Path]:
    """Every image under ``root`` (recursively; ``pipeline.images.PHOTO_EXTS``)."""
    return list_photos(root, recursive=True)


class PhotoSplit(NamedTuple):
    """Background photo paths of the FMG's three parts."""

    train: list[Path]
    dev: list[Path]
    """Development: validation during training and every choice (``FMG_DEV_SCENES``)."""
    test: list[Path]
    """Reported only (``HELDOUT_SCENES``, ``HELDOUT_BACKGROUNDS``)."""


def split_backgrounds(data: Path) -> PhotoSplit:
    """The image paths under ``data``/backgrounds and ``data``/scenes, split in three
    (``REAL_FLARE_PHOTOS`` in none)."""
    bg, sc = data / "backgrounds", data / "scenes"
    if not bg.is_dir() and not sc.is_dir():
        raise UserError(f"{data} has neither backgrounds/ nor scenes/: pass --data pointing "
                        "at a folder with photos in backgrounds/ and/or scenes/<scene>/")
    parts = PhotoSplit([], [], [])
    for p in (find_images(bg) if bg.is_dir() else []):
        (parts.test if p.stem in HELDOUT_BACKGROUNDS else parts.train).append(p)
    for p in (find_images(sc) if sc.is_dir() else []):
        scene = p.relative_to(sc).parts[0]
        if f"{scene}/{p.stem}" in REAL_FLARE_PHOTOS:
            continue
        (parts.test if scene in HELDOUT_SCENES else parts.dev
         if scene in FMG_DEV_SCENES else parts.train).append(p)
    return parts


def load_backgrounds(paths: list[Path], long_side: int) -> list[np.ndarray]:
    """RGB uint8 images, downscaled so their long side is at most ``long_side`` (files
    that cannot be read are left out)."""
    out = []
    for p in paths:
        try:
            img = read_image(p)
        except UserError:
            continue
        s = long_side / max(img.shape[:2])
        if s < 1:
            img = cv2.resize(img, None, fx=s, fy=s, interpolation=cv2.INTER_AREA)
        out.append(img)
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


# --------------------------------------------------------------------------- hard negatives
def _smooth_noise(size: int, scale: float, rng: np.random.Generator) -> np.ndarray:
    """[S, S] float32 smooth random field, zero mean, unit std, features about ``scale`` px."""
    n = max(2, int(round(size / max(scale, 1.0))))
    f = cv2.resize(rng.standard_normal((n, n)).astype(np.float32), (size, size),
                   interpolation=cv2.INTER_CUBIC)
    return (f - f.mean()) / (f.std() + 1e-6)


def _disc_alpha(size: int, cx: float, cy: float, rx: float, ry: float,
                angle: float) -> np.ndarray:
    """[S, S] anti-aliased filled ellipse (1 inside, 0 outside, a one-pixel edge)."""
    yy, xx = np.mgrid[0:size, 0:size].astype(np.float32)
    c, s = np.float32(np.cos(angle)), np.float32(np.sin(angle))
    u, v = (xx - cx) * c + (yy - cy) * s, -(xx - cx) * s + (yy - cy) * c
    d = np.sqrt((u / rx) ** 2 + (v / ry) ** 2)
    return np.clip((1.0 - d) * min(rx, ry) + 0.5, 0, 1).astype(np.float32)


def _blend(lin: np.ndarray, alpha: np.ndarray, rgb: np.ndarray) -> None:
    """lin [S, S, 3] <- lin (1 - alpha) + alpha rgb, in place; alpha [S, S]; rgb [3] or
    [S, S, 3] linear light."""
    a = alpha[..., None]
    lin *= 1 - a
    lin += a * rgb


def _neg_lamp(lin: np.ndarray, rng: np.random.Generator) -> None:
    """Lamps and bare light cores: saturated discs, ellipses or lit windows with a sharp edge
    and no halo (a light without flare, as the synthesizer's own core)."""
    S = lin.shape[0]
    for _ in range(int(rng.integers(1, 5))):
        rgb = fl.blackbody_rgb(rng.uniform(2000, 7000)) * np.float32(
            np.exp(rng.uniform(np.log(0.8), np.log(8.0))))
        cx, cy = rng.uniform(0, S, 2)
        r = S * float(np.exp(rng.uniform(np.log(0.004), np.log(0.06))))
        if rng.random() < 0.25:  # a lit window or panel: a rectangle
            w, h = r * rng.uniform(1, 3), r * rng.uniform(1, 3)
            a = np.zeros((S, S), np.float32)
            cv2.rectangle(a, (int(cx - w), int(cy - h)), (int(cx + w), int(cy + h)), 1.0, -1,
                          cv2.LINE_AA)
        else:
            a = _disc_alpha(S, cx, cy, r, r * rng.uniform(0.5, 1.0), rng.uniform(0, np.pi))
        if rng.random() < 0.5:  # a diffuser globe: brighter centre, dimmer rim, same edge
            g = _disc_alpha(S, cx, cy, 0.6 * r, 0.6 * r, 0.0)
            rgb_map = rgb * (0.35 + 0.65 * g[..., None])
            _blend(lin, a, rgb_map)
        else:
            _blend(lin, a, rgb)


def _neg_specular(lin: np.ndarray, rng: np.random.Generator) -> None:
    """Specular highlights: clusters of small sharp bright glints (metal, glass, water)."""
    S = lin.shape[0]
    add = np.zeros((S, S), np.float32)
    for _ in range(int(rng.integers(1, 3))):
        c = rng.uniform(0, S, 2)
        spread = S * rng.uniform(0.03, 0.25)
        for _ in range(int(rng.integers(3, 25))):
            x, y = c + rng.normal(0, spread, 2)
            sig = rng.uniform(0.6, 3.0)
            ax = (int(round(x)), int(round(y)))
            axes = (max(1, int(sig * rng.uniform(1, 4))), max(1, int(sig)))
            cv2.ellipse(add, ax, axes, float(rng.uniform(0, 180)), 0, 360,
                        float(np.exp(rng.uniform(np.log(0.5), np.log(4.0)))), -1, cv2.LINE_AA)
    add = cv2.GaussianBlur(add, (0, 0), 0.7)
    tint = 0.8 + 0.2 * fl.blackbody_rgb(rng.uniform(3500, 8000))
    lin += add[..., None] * tint


def _above_horizon(S: int, rng: np.random.Generator,
                   height: tuple[float, float]) -> tuple[float, np.ndarray, np.ndarray]:
    """An irregular horizon at a mean ``height`` (a fraction of the side, drawn in that range)
    from the top: (its mean row, the rows [S, 1], the anti-aliased alpha [S, S] of what
    lies above it)."""
    base = S * rng.uniform(*height)
    horizon = base + S * 0.08 * _smooth_noise(S, S / rng.uniform(2, 12), rng)[0]
    yy = np.arange(S, dtype=np.float32)[:, None]
    return base, yy, np.clip(horizon[None, :] - yy + 0.5, 0, 1)


def _neg_sky(lin: np.ndarray, rng: np.random.Generator) -> None:
    """Bright sky above an irregular horizon: a smooth gradient, clear blue to overcast
    white, with soft clouds."""
    S = lin.shape[0]
    base, yy, alpha = _above_horizon(S, rng, (0.15, 0.6))
    top = np.array([rng.uniform(0.2, 0.6), rng.uniform(0.4, 0.8), 1.0], np.float32)
    if rng.random() < 0.4:  # overcast
        top = np.full(3, 1.0, np.float32)
    level = np.float32(np.exp(rng.uniform(np.log(0.4), np.log(1.5))))
    grad = (yy / max(base, 1.0)).clip(0, 1)[..., None]  # brighter, whiter towards the horizon
    sky = level * (top * (1 - 0.5 * grad) + 0.5 * grad)
    clouds = np.clip(_smooth_noise(S, S / rng.uniform(3, 8), rng), 0, None)[..., None]
    sky = sky + np.float32(rng.uniform(0, 0.4)) * level * clouds
    _blend(lin, alpha, np.broadcast_to(sky, lin.shape))


def _neg_clouds(lin: np.ndarray, rng: np.random.Generator) -> None:
    """Fair-weather clouds: white and grey cumulus with soft but defined edges, brightest
    on their sunlit tops, on a deep blue sky above an irregular horizon (what the
    full-width networks marked as flare on clean street photos: docs/history/fmg.md,
    "Twenty-second session")."""
    S = lin.shape[0]
    base, yy, alpha = _above_horizon(S, rng, (0.25, 0.7))
    level = np.float32(np.exp(rng.uniform(np.log(0.5), np.log(1.5))))
    blue = np.array([rng.uniform(0.03, 0.15), rng.uniform(0.12, 0.35), rng.uniform(0.5, 1.0)],
                    np.float32)
    grad = (yy / max(base, 1.0)).clip(0, 1)[..., None]  # paler towards the horizon
    sky = level * (blue * (1 - 0.4 * grad) + 0.25 * grad)
    size = S / rng.uniform(2.5, 8)  # cloud scale: a few large cumulus to many small ones
    dens = (_smooth_noise(S, size, rng) + 0.5 * _smooth_noise(S, size / 3, rng)
            + 0.25 * _smooth_noise(S, size / 9, rng))
    cover = np.quantile(dens, 1 - rng.uniform(0.1, 0.45))  # 10-45 % of the sky clouded
    cloud = np.clip((dens - cover) * rng.uniform(1.5, 6), 0, 1)
    smooth = cv2.GaussianBlur(dens, (0, 0), max(size / 6, 1.0))
    dy = np.gradient(smooth, axis=0)
    lit = np.clip(0.85 - 0.2 * dy / (dy.std() + 1e-6), 0.45, 1.1)  # sunlit tops, grey bases
    white = level * np.float32(rng.uniform(0.8, 2.0)) * lit[..., None] * (
        0.92 + 0.08 * fl.blackbody_rgb(rng.uniform(5000, 9000)))
    sky = sky * (1 - cloud[..., None]) + cloud[..., None] * white
    _blend(lin, alpha, sky.astype(np.float32))


def _neg_wall(lin: np.ndarray, rng: np.random.Generator) -> None:
    """White walls and facades: large bright quadrilaterals with gentle shading and texture."""
    S = lin.shape[0]
    for _ in range(int(rng.integers(1, 3))):
        c = rng.uniform(0, S, 2)
        half = S * rng.uniform(0.1, 0.45, 2)
        quad = np.array([c + half * [-1, -1], c + half * [1, -1], c + half * [1, 1],
                         c + half * [-1, 1]]) + rng.normal(0, S * 0.04, (4, 2))
        a = np.zeros((S, S), np.float32)
        cv2.fillConvexPoly(a, np.round(quad * 16).astype(np.int32), 1.0, cv2.LINE_AA, 4)
        level = np.float32(rng.uniform(0.5, 1.3))
        shade = 1 + 0.15 * _smooth_noise(S, S / 2, rng) + 0.05 * _smooth_noise(S, 3, rng)
        rgb = level * (0.9 + 0.1 * fl.blackbody_rgb(rng.uniform(4000, 9000)))
        _blend(lin, a, shade[..., None] * rgb)


def _neg_foliage(lin: np.ndarray, rng: np.random.Generator) -> None:
    """Red and orange (autumn) foliage: a blobby region of leafy red / orange texture, sunlit
    or lit by a lamp; it keeps the photo's own texture."""
    S = lin.shape[0]
    region = _smooth_noise(S, S / rng.uniform(2, 6), rng)
    alpha = np.clip((region - rng.uniform(-0.3, 1.0)) * 3, 0, 1)
    leaves = np.clip(0.6 + 0.5 * _smooth_noise(S, rng.uniform(1.5, 5), rng), 0.05, 1.5)
    own = fl.luminance(lin)
    own = own / (float(own.mean()) + 1e-3)
    tex = leaves * np.clip(0.5 + 0.5 * own, 0.2, 2.0)
    hue = rng.uniform(0, 40)  # red to orange
    col = srgb_to_linear(fl.hsv_rgb(hue, rng.uniform(0.6, 1.0)))
    level = np.float32(np.exp(rng.uniform(np.log(0.1), np.log(0.9))))
    _blend(lin, alpha, level * tex[..., None] * col)


def _neg_backlit(lin: np.ndarray, rng: np.random.Generator) -> None:
    """Foliage backlit at night: the dark crown of a tree (leaves and twigs, dense inside,
    ragged at its edge) in front of a light's glow (a street lamp behind the tree, the haze
    it lights), so the glow shows through the gaps between the leaves and rims their edges.
    The glow is drawn only behind the crown: what tells it from veiling glare is that it lies
    behind the leaves (they stay dark), where lens glare lies over everything. (What the
    full-width networks marked beside the lamp of a real night photo: docs/history/fmg.md,
    "Twenty-fourth session".)"""
    S = lin.shape[0]
    region = _smooth_noise(S, S / rng.uniform(1.5, 4), rng)
    crown = np.clip((region - rng.uniform(-0.6, 0.6)) * 2.5, 0, 1)
    inside = np.flatnonzero(crown.ravel() > 0.5)
    if len(inside) == 0:
        return
    cy, cx = np.divmod(float(inside[int(rng.integers(len(inside)))]), S)  # light behind it
    yy, xx = np.mgrid[0:S, 0:S].astype(np.float32)
    d2 = ((xx - cx) ** 2 + (yy - cy) ** 2) / np.float32(S * rng.uniform(0.06, 0.35)) ** 2
    colour = fl.blackbody_rgb(rng.uniform(1900, 4500))
    peak = np.float32(np.exp(rng.uniform(np.log(0.5), np.log(12.0))))
    sky = np.array([0.004, 0.006, 0.015], np.float32) * np.float32(rng.uniform(0.3, 3))
    glow = sky + (peak / (1.0 + d2))[..., None] * colour
    fine = (0.5 * _smooth_noise(S, rng.uniform(1.2, 3.0), rng)  # leaf edges
            + _smooth_noise(S, rng.uniform(4, 12), rng)  # clusters of leaves
            + 0.5 * _smooth_noise(S, rng.uniform(15, 40), rng))  # branches and large gaps
    density = np.float32(rng.uniform(0.0, 1.5))  # sparse to dense leaves
    leaves = np.clip((fine + density + 1.5 * (crown - 0.5)) * 2.0, 0, 1).astype(np.float32)
    dark = np.array([0.006, 0.008, 0.004], np.float32) * np.float32(rng.uniform(0.3, 3))
    rim = cv2.GaussianBlur(1 - leaves, (0, 0), 1.0) * leaves  # leaf edges next to a gap
    front = dark + (rim * np.float32(rng.uniform(0.02, 0.15)))[..., None] * glow
    scene = glow * (1 - leaves[..., None]) + front * leaves[..., None]
    _blend(lin, cv2.GaussianBlur(crown, (0, 0), 1.5), scene.astype(np.float32))


def _neg_neon(lin: np.ndarray, rng: np.random.Generator) -> None:
    """Neon signs: thin saturated polylines and arcs, a near-white core with a tight glow of
    their own colour (a lit tube, not lens flare)."""
    S = lin.shape[0]
    tube = np.zeros((S, S), np.float32)
    for _ in range(int(rng.integers(1, 4))):
        if rng.random() < 0.6:
            pts = rng.uniform(0.1 * S, 0.9 * S, (int(rng.integers(2, 6)), 2))
            cv2.polylines(tube, [np.round(pts).astype(np.int32)], bool(rng.random() < 0.3),
                          1.0, int(rng.integers(1, 5)), cv2.LINE_AA)
        else:
            c = tuple(int(v) for v in rng.uniform(0.2 * S, 0.8 * S, 2))
            ax = tuple(int(v) for v in rng.uniform(0.03 * S, 0.2 * S, 2))
            a0 = float(rng.uniform(0, 360))
            cv2.ellipse(tube, c, ax, 0.0, a0, a0 + float(rng.uniform(90, 360)), 1.0,
                        int(rng.integers(1, 5)), cv2.LINE_AA)
    col = fl.hsv_rgb(rng.uniform(0, 360), rng.uniform(0.7, 1.0))
    level = np.float32(np.exp(rng.uniform(np.log(0.6), np.log(4.0))))
    glow = cv2.GaussianBlur(tube, (0, 0), rng.uniform(1.0, 3.0)) * np.float32(
        rng.uniform(0.1, 0.4))
    lin += level * (tube[..., None] * (0.6 * col + 0.4) + glow[..., None] * col)


def _neg_reflection(lin: np.ndarray, rng: np.random.Generator) -> None:
    """Reflections in water or glass: the part above a line mirrored below it, stretched,
    rippled and dimmed (lamps above become vertical glints below)."""
    S = lin.shape[0]
    y0 = int(S * rng.uniform(0.35, 0.8))
    stretch = rng.uniform(1.0, 2.5)
    ys = np.arange(y0, S, dtype=np.float32)
    src_y = y0 - 1 - (ys - y0) / stretch
    xx = np.arange(S, dtype=np.float32)[None, :]
    amp, period = rng.uniform(0, 4), rng.uniform(4, 30)
    map_x = (xx + amp * np.sin(ys[:, None] / period * 2 * np.pi + rng.uniform(0, 6))).astype(
        np.float32)
    map_y = np.broadcast_to(np.clip(src_y, 0, S - 1)[:, None], map_x.shape).astype(np.float32)
    refl = cv2.remap(np.ascontiguousarray(lin), map_x, map_y, cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_REFLECT)
    refl = cv2.GaussianBlur(refl, (0, 0), rng.uniform(0.3, 2.0))
    k = np.float32(rng.uniform(0.25, 0.8))
    lin[y0:] = (1 - k) * lin[y0:] * np.float32(rng.uniform(0.2, 0.7)) + k * refl


_NEGATIVES = {"lamp": _neg_lamp, "specular": _neg_specular, "sky": _neg_sky,
              "clouds": _neg_clouds, "wall": _neg_wall, "foliage": _neg_foliage,
              "backlit": _neg_backlit, "neon": _neg_neon, "reflection": _neg_reflection}


def add_hard_negatives(img: np.ndarray, rng: np.random.Generator,
                       kinds: tuple[str, ...] | None = None,
                       pool: tuple[str, ...] = DEFAULT_NEGATIVES) -> np.ndarray:
    """Paint 1-3 kinds of bright non-flare content (drawn from ``pool``, or ``kinds``) onto an
    sRGB float image [S, S, 3], in linear light; returns the new sRGB float32 image.

    - ``lamp``: lamps and bare light cores (1-4 saturated discs, ellipses, lit windows; some
      diffuser globes), sharp-edged, no halo: a light is not flare.
    - ``specular``: clusters of small sharp glints.
    - ``sky``: bright sky above an irregular horizon (clear to overcast, soft clouds).
    - ``clouds``: white and grey cumulus with defined edges on a deep blue sky.
    - ``wall``: large bright white quadrilaterals (walls, facades) with gentle shading.
    - ``foliage``: red / orange leafy texture, dim to sunlit.
    - ``backlit``: a dark tree crown at night in front of a lamp's glow, which shows through
      the gaps between the leaves (the leaves stay dark: the glow is behind them).
    - ``neon``: thin saturated lines and arcs with a tight glow of their own.
    - ``reflection``: the image above a line mirrored below it, stretched, rippled, dimmed
      (drawn last, so it reflects the others: lamps become vertical glints).
    Nothing here is flare: composites keep their label (flare added later is masked where
    it is visible against this brighter background)."""
    if kinds is None:
        n = min(int(rng.integers(1, 4)), len(pool))
        kinds = tuple(rng.choice(pool, size=n, replace=False)) if n else ()
    lin = np.ascontiguousarray(srgb_to_linear(img), np.float32)
    for k in sorted(kinds, key=lambda k: k == "reflection"):
        _NEGATIVES[k](lin, rng)
    return linear_to_srgb(lin).astype(np.float32)


def training_flare(without: tuple[str, ...] = (),
                   kind_probs: dict[str, float] | None = None) -> fl.FlareConfig:
    """The flare of FMG training composites: default ``FlareConfig`` with every kind of
    ``flare.KINDS`` except those in ``without`` (a leave-one-kind-out model), each kind of
    ``kind_probs`` drawn with the probability given there."""
    without = fl.check_kinds(without, "--without") if without else ()
    kinds = tuple(k for k in fl.KINDS if k not in without)
    if not kinds:
        raise UserError("--without leaves no kind of flare to train on")
    return fl.FlareConfig(kinds=kinds).with_kind_probs(kind_probs or {})


def darken_night(img: np.ndarray, cfg: CompositeConfig,
                 rng: np.random.Generator) -> np.ndarray:
    """Dusk / night version of an sRGB float image [S, S, 3]: linear light x a small gain,
    with a random cool (blue) tint."""
    g = float(np.exp(rng.uniform(*np.log(cfg.night_gain))))
    tint = np.array([1.0 - rng.uniform(0, 0.3), 1.0 - rng.uniform(0, 0.15), 1.0], np.float32)
    return linear_to_srgb(srgb_to_linear(img) * np.float32(g) * tint).astype(np.float32)


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


def window_layers(layers: fl.FlareLayers, x0: int, y0: int, size: int) -> fl.FlareLayers:
    """The ``size`` x ``size`` window of ``layers`` with its top-left at (x0, y0), the light
    and ghost positions moved into the window's pixels."""
    def cut(a: np.ndarray) -> np.ndarray:
        return np.ascontiguousarray(a[y0:y0 + size, x0:x0 + size])

    lx, ly = layers.light_xy
    return dataclasses.replace(
        layers, flare=cut(layers.flare), core=cut(layers.core), mask=cut(layers.mask),
        light_xy=(lx - x0, ly - y0), ghost_xy=[(x - x0, y - y0) for x, y in layers.ghost_xy])


def draw_flare(flare_cfg: fl.FlareConfig, comp: CompositeConfig, size: int,
               rng: np.random.Generator) -> fl.FlareLayers:
    """A fresh lens (kinds from ``flare_cfg.kinds``) at a random light, rendered for a
    ``size`` square, or (``comp.flare_canvas`` > 1) for a square that many times larger of
    which a ``size`` window is kept, placed so the light falls inside it (or, for a light
    outside the larger frame, as near it as the frame allows)."""
    lens = fl.sample_lens(flare_cfg, rng)
    big = max(size, round(size * comp.flare_canvas))
    light = fl.sample_light_xy(flare_cfg, (big, big), rng)
    k = fl.sample_intensity(flare_cfg, rng)
    layers = fl.render_flare(lens, light, (big, big), rng, k)
    if big == size:
        return layers
    x0, y0 = (int(np.clip(round(c - size * rng.uniform(0.1, 0.9)), 0, big - size))
              for c in light)
    return window_layers(layers, x0, y0, size)


def frame_window(bg: np.ndarray, size: int, rng: np.random.Generator
                 ) -> tuple[int, int] | None:
    """The top-left corner (x0, y0) of a random ``size`` window of the photo ``bg`` at its
    own scale, or None when the photo is smaller than the window."""
    h, w = bg.shape[:2]
    if min(h, w) < size:
        return None
    return int(rng.integers(0, w - size + 1)), int(rng.integers(0, h - size + 1))


def frame_crop(bg: np.ndarray, window: tuple[int, int], size: int,
               rng: np.random.Generator) -> np.ndarray:
    """The window of ``bg`` (RGB uint8) as float32 sRGB [0, 1], not resized, randomly
    flipped (the flare is drawn after, so its geometry keeps the photo's)."""
    x0, y0 = window
    crop = bg[y0:y0 + size, x0:x0 + size]
    if rng.random() < 0.5:
        crop = crop[:, ::-1]
    return np.ascontiguousarray(crop, np.float32) / 255.0


def draw_frame_flare(flare_cfg: fl.FlareConfig, frame_hw: tuple[int, int],
                     window: tuple[int, int], size: int,
                     rng: np.random.Generator) -> fl.FlareLayers:
    """A fresh lens at a light inside ``window`` (10-90 % of its side, as
    :func:`draw_flare` keeps it), rendered for the whole ``frame_hw`` photo with the optical
    centre at the photo's centre (ghosts and streaks laid out as ``synth`` lays them out on a
    photo), then the window's ``size`` square kept."""
    x0, y0 = window
    lens = fl.sample_lens(flare_cfg, rng)
    light = (x0 + size * float(rng.uniform(0.1, 0.9)), y0 + size * float(rng.uniform(0.1, 0.9)))
    k = fl.sample_intensity(flare_cfg, rng)
    return window_layers(fl.render_flare(lens, light, frame_hw, rng, k), x0, y0, size)


def composite_flare(img: np.ndarray, flare_cfg: fl.FlareConfig, comp: CompositeConfig,
                    rng: np.random.Generator, window: tuple[int, int] | None = None,
                    frame_hw: tuple[int, int] | None = None, with_clean: bool = False
                    ) -> tuple:
    """Flare an sRGB float image [S, S, 3]: (flared sRGB [S, S, 3] float32, mask [S, S] bool),
    and with ``with_clean`` the photo as the same exposure shows it without the flare, the
    light's core and the noise (sRGB float32, from the same draws: what a perfect de-flaring
    would give back where the mask is; the core is never in the mask).

    A fresh lens at a random light position (:func:`draw_flare`), its layers moved by one
    random affine; or, given the ``window`` ``img`` was cut from a ``frame_hw`` photo
    (``CompositeConfig.frame_prob``), the lens drawn for that photo
    (:func:`draw_frame_flare`) with no affine. The mask is kept where the flare is visible
    against this background.
    """
    S = img.shape[0]
    if window is None:
        layers = draw_flare(flare_cfg, comp, S, rng)
        m = random_affine(comp, layers.light_xy, rng)
        layers = warp_layers(layers, m, S)
    else:
        if frame_hw is None:
            raise ValueError("composite_flare: a window needs the photo's frame_hw")
        layers = draw_frame_flare(flare_cfg, frame_hw, window, S, rng)
    label = layers.mask
    gain = float(rng.uniform(*flare_cfg.gain))
    noise = float(rng.uniform(*flare_cfg.noise))
    visible = fl.flare_mask(layers.flare, layers.core, flare_cfg,
                            srgb_to_linear(img) * gain)
    layers = dataclasses.replace(layers, mask=label & visible)
    flared = fl.apply_flare(img, layers, rng, noise, gain)
    if not with_clean:
        return flared, layers.mask
    return flared, layers.mask, linear_to_srgb(srgb_to_linear(img) * np.float32(gain))


class CompositeSource:
    """Draws (image [S, S, 3] float32 sRGB, mask [S, S] bool) composites from backgrounds."""

    def __init__(self, backgrounds: list[np.ndarray], flare_cfg: fl.FlareConfig | None = None,
                 comp: CompositeConfig | None = None):
        if not backgrounds:
            raise UserError("no background photos found for FMG composites")
        self.backgrounds = backgrounds
        self.flare_cfg = flare_cfg or fl.FlareConfig()
        self.comp = comp or CompositeConfig()
        self.night_flare_cfg = self.flare_cfg  # the flare of night composites
        if self.comp.night_glare != 1.0 and "glare" in self.flare_cfg.kinds:
            p = min(1.0, self.flare_cfg.kind_prob("glare") * self.comp.night_glare)
            self.night_flare_cfg = self.flare_cfg.with_kind_probs({"glare": p})

    def sample(self, rng: np.random.Generator, train: bool = True,
               extras: bool | None = None, with_clean: bool = False) -> tuple:
        """One composite (image, mask). ``train`` adds jitter, distractors, hard negatives and
        flare-free samples; ``extras`` (default: ``train``) enables night backgrounds;
        ``with_clean`` adds the image without its flare (``composite_flare``), from the same
        draws."""
        c = self.comp
        extras = train if extras is None else extras
        bg = self.backgrounds[int(rng.integers(len(self.backgrounds)))]
        window = None  # no draw at frame_prob 0: the composites of earlier runs stay as they were
        if train and c.frame_prob > 0 and rng.random() < c.frame_prob:
            window = frame_window(bg, c.size, rng)
        img = (random_crop(bg, c.size, c.crop_scale, rng) if window is None
               else frame_crop(bg, window, c.size, rng))
        night = extras and rng.random() < c.night_prob
        if night:
            img = darken_night(img, c, rng)
        if train:
            img = colour_jitter(img, c.jitter, rng)
            if rng.random() < c.distractor_prob:
                img = add_distractors(img, rng)
            flared = rng.random() < c.flare_prob
            if rng.random() < (c.negative_prob if flared else c.clean_negative_prob):
                img = add_hard_negatives(img, rng, pool=c.negatives)
            if not flared:
                none = np.zeros(img.shape[:2], bool)
                return (img, none, img) if with_clean else (img, none)
        return composite_flare(img, self.night_flare_cfg if night else self.flare_cfg, c, rng,
                               window, bg.shape[:2], with_clean)

    def batch(self, n: int, rng: np.random.Generator, train: bool = True,
              extras: bool | None = None, with_clean: bool = False):
        """(images [n, 3, S, S] float32, masks [n, 1, S, S] float32) as torch tensors; with
        ``with_clean`` also the images without their flare [n, 3, S, S]."""
        import torch

        draws = [self.sample(rng, train, extras, with_clean) for _ in range(n)]

        def images(k: int):
            return torch.from_numpy(np.stack([d[k] for d in draws])).permute(0, 3, 1, 2)

        y = torch.from_numpy(np.stack([d[1] for d in draws]))[:, None].float()
        if with_clean:
            return images(0).contiguous(), y, images(2).contiguous()
        return images(0).contiguous(), y


def fixed_set(source: CompositeSource, n: int, seed: int, extras: bool = False,
              with_clean: bool = False) -> tuple:
    """A deterministic validation set: n evaluation composites (every one flared); with
    ``extras``, night backgrounds as configured in ``source.comp``; with ``with_clean``, the
    images without their flare as a third tensor (the same composites either way)."""
    return source.batch(n, np.random.default_rng(seed), train=False, extras=extras,
                        with_clean=with_clean)
