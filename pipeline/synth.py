"""Stage ``synth``: impose 3D-consistent synthetic lens flare on a posed clean scene.

Input: a posed workspace of clean photos (``WS/images/<stem>.png`` + ``WS/cameras.json``).
One lens is drawn per scene (:func:`pipeline.flare.sample_lens`; the kinds of flare it
combines come from ``SynthConfig.flare.kinds``, ``--kinds``) and one point light is
placed in the world (near the scene, in front of most cameras, or given). The light is
projected with each view's ``K`` and ``c2w``; that view's flare is the lens rendered at the
projection, with the principal point as optical centre, so streaks and ghosts move with the
camera as real flare does. Intensity varies mildly per view (ghost reflections depend on
the angle of incidence); a light outside the frame fades with its distance from it; a
light behind the camera gives no flare. Limitation: with no scene depth the light is never
occluded, so pick ``--light`` in free space when the default placement (0.25-0.8 of the
camera distance from the point the cameras look at) lands inside an object.

Output folder ``DIR`` (never inside the workspace or the photo folder):
```
DIR/photos/<stem>.png    flared photos a user would have (held-out views left out)
DIR/clean/<stem>.png     ground truth, every view: the clean photo plus the light's core
DIR/masks_gt/<stem>.png  255 = flare, every view (held-out: the flare they would have had)
DIR/cameras_gt.json      WS/cameras.json, every view
DIR/split.json           {"train", "heldout", "seed", "kinds", "light_world", "origin", "lens",
                          "views"}  (kinds: those allowed; lens.kinds: those drawn)
DIR/README.md            how it was made
DIR/manifest.json        this stage's bookkeeping (skip when up to date, resume)
```
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pipeline.cameras import Cameras, Frame, save_cameras
from pipeline.colour import srgb_to_linear
from pipeline.errors import UserError
from pipeline.flare import (
    KINDS,
    FlareConfig,
    FlareLayers,
    Lens,
    apply_flare,
    psf_bank,
    render_flare,
    sample_intensity,
    sample_lens,
)
from pipeline.options import option, validate
from pipeline.progress import info, track
from pipeline.workspace import Workspace, atomic_imwrite, atomic_write_json, atomic_write_text
from pipeline.ws_files import read_cameras, read_view_image


@dataclass
class SynthConfig:
    """Parameters of ``deflare-scene synth WS --out DIR``."""

    out: Path
    """Output folder (not inside the workspace or the photo folder)."""
    seed: int = option(0, ge=0)
    """Seed of the lens, light, intensities and which views get flare."""
    light: tuple[float, float, float] | None = option(None, metavar="X,Y,Z")
    """Light position in the normalised world frame; default: chosen from the cameras."""
    heldout: int | None = option(None, ge=0)
    """Hold out this many views, evenly spread (instead of ``heldout_every``)."""
    heldout_every: int = option(8, ge=0)
    """Hold out every K-th view (index % K == 0, the LLFF convention); 0 = none."""
    flare_prob: float = option(1.0, ge=0, le=1)
    """Fraction of views that get flare (the others still show the light's core)."""
    intensity_jitter: float = option(0.15, ge=0)
    """Log-normal sigma of the per-view flare intensity around the scene's."""
    fade_distance: float = option(0.35, gt=0)
    """A light outside the frame fades as exp(-(d / (this x diagonal))^2)."""
    flare: FlareConfig = field(default_factory=FlareConfig)
    """Ranges of the flare synthesizer."""

    def params(self) -> dict:
        d = dataclasses.asdict(self)
        d.pop("out")
        return d


# --------------------------------------------------------------------------- geometry
def project(frame: Frame, point: np.ndarray) -> tuple[float, float] | None:
    """Pixel (x, y) of world ``point`` [3] in ``frame``, or None when behind the camera."""
    p = frame.w2c @ np.append(point, 1.0)
    if p[2] <= 1e-6:
        return None
    uv = frame.K @ (p[:3] / p[2])
    return float(uv[0]), float(uv[1])


def _focus_point(cams: Cameras) -> np.ndarray:
    """[3] the point nearest every optical axis (least squares), or the centroid ahead."""
    centres = cams.centers()
    dirs = np.stack([f.c2w[:3, 2] for f in cams.frames])
    proj = np.eye(3)[None] - dirs[:, :, None] * dirs[:, None, :]  # [N, 3, 3]
    A, b = proj.sum(0), (proj @ centres[:, :, None]).sum(0)[:, 0]
    far = np.median([f.far for f in cams.frames])
    if np.linalg.cond(A) < 1e6:
        p = np.linalg.solve(A, b)
        depths = np.einsum("nk,nk->n", p - centres, dirs)
        if np.median(depths) > 0 and np.linalg.norm(p - centres.mean(0)) < far:
            return p
    # near-parallel axes (a forward-facing capture): mid-depth ahead of the cameras
    depth = np.median([(f.near + f.far) / 2 for f in cams.frames])
    return centres.mean(0) + dirs.mean(0) * depth


def _in_frame_count(cams: Cameras, point: np.ndarray, margin: float = 0.05) -> int:
    n = 0
    for f in cams.frames:
        z = (f.w2c @ np.append(point, 1.0))[2]
        xy = project(f, point)
        if xy is None or z < f.near:
            continue
        mx, my = margin * f.width, margin * f.height
        n += mx <= xy[0] < f.width - mx and my <= xy[1] < f.height - my
    return n


def choose_light(cams: Cameras, rng: np.random.Generator, n_candidates: int = 256) -> np.ndarray:
    """[3] a light near the scene that projects into as many views as possible.

    Candidates are drawn around the point the cameras look at, at 0.25-0.8 of the median
    camera distance; among those inside the most frames one is picked at random.
    """
    focus = _focus_point(cams)
    radius = float(np.median(np.linalg.norm(cams.centers() - focus, axis=1)))
    u = rng.normal(size=(n_candidates, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    cands = focus + u * radius * rng.uniform(0.25, 0.8, (n_candidates, 1))
    scores = np.array([_in_frame_count(cams, c) for c in cands])
    best = np.flatnonzero(scores == scores.max())
    return cands[int(rng.choice(best))]


def heldout_indices(n: int, heldout: int | None, every: int) -> list[int]:
    """Indices of held-out views: ``heldout`` evenly spread, else every ``every``-th."""
    if heldout is not None:
        if not 0 <= heldout <= n - 2:
            raise UserError(f"--heldout {heldout}: the scene has {n} views and at least 2 "
                            "must stay for training; choose fewer")
        return sorted({int(round(x)) for x in np.linspace(0, n - 1, heldout + 2)[1:-1]})
    if every < 0:
        raise UserError(f"--heldout-every {every} must be >= 0 (0 = hold out nothing)")
    idx = [i for i in range(n) if every and i % every == 0]
    if n - len(idx) < 2:
        raise UserError(f"--heldout-every {every} leaves fewer than 2 training views of {n}")
    return idx


def _fade(xy: tuple[float, float], w: int, h: int, fade_distance: float) -> float:
    """1 inside the frame, Gaussian falloff with the distance outside it."""
    dx = max(-xy[0], 0.0, xy[0] - (w - 1))
    dy = max(-xy[1], 0.0, xy[1] - (h - 1))
    d = np.hypot(dx, dy) / (fade_distance * np.hypot(w, h))
    return float(np.exp(-d * d))


# --------------------------------------------------------------------------- stage
def _check_out(cfg: SynthConfig, ws: Workspace) -> Path:
    out = Path(cfg.out).resolve()
    photos = ws.photos_dir
    if photos is not None and (out == photos.resolve() or out.is_relative_to(photos.resolve())):
        raise UserError(f"--out {out} is inside the photo folder {photos}: choose a folder "
                        "outside it (the photo folder is never written)")
    if out == ws.root or out.is_relative_to(ws.root) or ws.root.is_relative_to(out):
        raise UserError(f"--out {out} overlaps the workspace {ws.root}: choose a separate "
                        "folder")
    if out.exists() and not out.is_dir():
        raise UserError(f"--out {out} exists and is not a folder: choose another")
    return out


def view_flare(cfg: SynthConfig, lens: Lens, frame: Frame, light: np.ndarray,
               base_intensity: float, index: int, clean_linear: np.ndarray
               ) -> tuple[FlareLayers, dict]:
    """The flare layers of one view and a JSON record of what was drawn."""
    rng = np.random.default_rng([cfg.seed, 1, index])
    has_flare = bool(rng.random() < cfg.flare_prob)
    xy = project(frame, light)
    H, W = frame.height, frame.width
    record = {"light_xy": None if xy is None else [round(v, 3) for v in xy]}
    if xy is None:  # behind the camera: no light, no flare
        z = np.zeros((H, W, 3), np.float32)
        return FlareLayers(z, z.copy(), np.zeros((H, W), bool)), {**record, "flare": False,
                                                                   "intensity": 0.0}
    k = base_intensity * float(np.exp(rng.normal(0, cfg.intensity_jitter)))
    k *= _fade(xy, W, H, cfg.fade_distance) if has_flare else 0.0
    layers = render_flare(lens, xy, (H, W), rng, k, clean_linear,
                          center_xy=(float(frame.K[0, 2]), float(frame.K[1, 2])))
    return layers, {**record, "flare": has_flare and k > 0, "intensity": round(k, 5)}


def _write_view(out: Path, stem: str, img: np.ndarray, layers: FlareLayers,
                train: bool) -> None:
    """Write clean (+core), mask and, for training views, the flared photo."""
    def to8(x: np.ndarray) -> np.ndarray:  # [H, W, 3] RGB float -> BGR uint8
        return np.round(x[..., ::-1] * 255).astype(np.uint8)

    core_only = FlareLayers(np.zeros_like(layers.flare), layers.core, layers.mask)
    atomic_imwrite(out / "clean" / f"{stem}.png", to8(apply_flare(img, core_only)))
    atomic_imwrite(out / "masks_gt" / f"{stem}.png", layers.mask.astype(np.uint8) * 255)
    if train:
        atomic_imwrite(out / "photos" / f"{stem}.png", to8(apply_flare(img, layers)))


def _read_image(ws: Workspace, frame: Frame) -> np.ndarray:
    """[H, W, 3] uint8 RGB of WS/images/<stem>.png, checked against cameras.json."""
    img = read_view_image(ws, frame.stem)
    if img.shape[:2] != (frame.height, frame.width):
        raise UserError(f"{ws.image_path(frame.stem)} is {img.shape[1]}x{img.shape[0]} but "
                        f"cameras.json says {frame.width}x{frame.height}: "
                        f"{ws.rerun('pose')}")
    return img


def run(cfg: SynthConfig, ws: Workspace, force: bool = False) -> list[Path]:
    """Write the flared scene to ``cfg.out``; returns the written paths."""
    validate(cfg)
    ws.require("pose")
    out = _check_out(cfg, ws)
    cams = read_cameras(ws)
    if len(cams.frames) < 3:
        raise UserError(f"{ws.cameras_json} has {len(cams.frames)} views; synth needs >= 3")
    held = set(heldout_indices(len(cams.frames), cfg.heldout, cfg.heldout_every))
    book = Workspace(out)
    stage_run = book.begin_stage("synth", {"workspace": str(ws.root), **cfg.params()},
                            [ws.images, ws.cameras_json], force)
    if stage_run.skip:
        info(f"synth: {out} is up to date (use --force to redo)")
        return stage_run.outputs
    rng = np.random.default_rng([cfg.seed, 0])
    lens = sample_lens(cfg.flare, rng)
    light = np.asarray(cfg.light, float) if cfg.light is not None else choose_light(cams, rng)
    base = sample_intensity(cfg.flare, rng)
    if "scatter" in lens.kinds:
        psf_bank(cfg.flare, progress=True)
    views = {}
    for i, frame in enumerate(track(cams.frames, "Imposing flare")):
        img = _read_image(ws, frame)
        layers, views[frame.stem] = view_flare(cfg, lens, frame, light, base, i,
                                               srgb_to_linear(img / 255.0))
        views[frame.stem]["flare_fraction"] = round(float(layers.mask.mean()), 5)
        names = ["clean", "masks_gt"] + ([] if i in held else ["photos"])
        if all(book.kept(stage_run, out / n / f"{frame.stem}.png") for n in names):
            continue
        _write_view(out, frame.stem, img, layers, i not in held)
    _remove_stale(out / "photos", set(cams.stems) - {cams.stems[i] for i in held})
    return stage_run.finish(_write_meta(cfg, out, ws, cams, held, light, lens, views))


def _remove_stale(folder: Path, keep: set[str]) -> None:
    """Delete photos of views that are no longer training views (an earlier split)."""
    for p in folder.glob("*.png") if folder.is_dir() else []:
        if p.stem not in keep:
            p.unlink()


def _write_meta(cfg: SynthConfig, out: Path, ws: Workspace, cams: Cameras, held: set[int],
                light: np.ndarray, lens: Lens, views: dict) -> list[Path]:
    stems = cams.stems
    split = {"train": [s for i, s in enumerate(stems) if i not in held],
             "heldout": [s for i, s in enumerate(stems) if i in held],
             "seed": cfg.seed, "kinds": list(cfg.flare.kinds),
             "light_world": [float(v) for v in light],
             "origin": ws.scene_name, "lens": lens.summary(), "views": views}
    save_cameras(out / "cameras_gt.json", cams)
    atomic_write_json(out / "split.json", split)
    n_flare = sum(v["flare"] for v in views.values())
    kinds_opt = "" if cfg.flare.kinds == KINDS else f" --kinds {','.join(cfg.flare.kinds)}"
    atomic_write_text(out / "README.md", f"""# Synthetic flare scene

Made by `deflare-scene synth {ws.root} --out {out} --seed {cfg.seed}{kinds_opt}` from the
clean posed workspace `{ws.root}` ({len(stems)} views). One lens (physically based flare
synthesizer, pipeline/flare/; kinds of flare allowed: {', '.join(cfg.flare.kinds)};
drawn: {', '.join(lens.kinds)}) and one point light at world
{np.round(light, 4).tolist()} shared by all views; the light is projected into each view,
so the flare moves with the camera.
{n_flare} of {len(stems)} views have flare (flare probability {cfg.flare_prob}).

- `photos/`: the flared photos a user would have ({len(split['train'])} views; the
  {len(split['heldout'])} held-out views are left out).
- `clean/`: ground truth for every view (clean photo plus the light source's core).
- `masks_gt/`: ground-truth flare masks (255 = flare) for every view.
- `cameras_gt.json`: the ground-truth cameras of every view (same format as cameras.json).
- `split.json`: train / held-out stems, seed, kinds, light position, lens and per-view
  draws.
""")
    return [out / "photos", out / "clean", out / "masks_gt", out / "cameras_gt.json",
            out / "split.json", out / "README.md"]
