"""Stage `mask`: flare-occupancy masks for every view (FMG, or masks the user annotated).

Reads ``WS/images/<stem>.png`` and writes
- ``WS/masks/<stem>.png``: uint8, 255 = flare, same size as the image
  (``pipeline.ws_files.write_mask``; read back with ``read_mask``);
- ``WS/flare.json``: where the masks came from and each view's flare fraction
  (``ws_files.FlareFile``);
- ``WS/masks_overview.jpg``: contact sheet of every view, mask tinted red, flare percentage;
- ``WS/masks_fmg/<stem>.png`` with ``--crosscheck`` or ``--ghost-views`` only: the
  network's masks before the other photos judged them (``pipeline.crosscheck``; WS/masks
  holds the judged ones);
- ``WS/masks_ghosts/<stem>.png`` with ``--ghost-views`` only: the ghost-line candidates the
  other photos judged (``pipeline.flare_ghosts``).

The FMG runs batched at a working resolution (long side ``work_size``) and its probability
map is upsampled to the image size, optionally refined to follow image edges with a guided
filter, then cut at ``threshold``.
"""

from __future__ import annotations

import hashlib
import math
import shutil
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import cv2
import numpy as np

from gnfr import WEIGHTS_DIR
from pipeline.errors import UserError
from pipeline.images import image_size, is_photo, put_label, read_image_as_stored
from pipeline.options import option, resolve_device, validate
from pipeline.progress import info, track
from pipeline.workspace import Workspace, atomic_imwrite, atomic_write_bytes
from pipeline.ws_files import (
    FlareEntry,
    FlareFile,
    enclosed_holes,
    flare_fraction,
    read_mask,
    read_mask_file,
    read_view_image,
    view_stems,
    write_flare,
    write_mask,
    write_mask_file,
)

DEFAULT_WEIGHTS = WEIGHTS_DIR / "fmg.safetensors"
"""The FMG weights shipped with the package (see gnfr/weights/fmg.md)."""
DEFAULT_CONFIRM_WEIGHTS = WEIGHTS_DIR / "fmg_candidate_L.safetensors"
"""The second network of ``--confirm``: the full-width FMG candidate (gnfr/weights/fmg.md, L;
J, which it was trained from, until the twenty-third session)."""


@dataclass
class MaskConfig:
    """Options of the mask stage."""

    weights: Path | None = option(None, exists=True)
    """FMG weights (safetensors); default: the shipped gnfr/weights/fmg.safetensors."""
    masks_dir: Path | None = option(None, flag="--masks")
    """Hand-annotated masks instead of the FMG: one image per stem, nonzero = flare."""
    threshold: float | None = option(None, ge=0, le=1)
    """Flare probability above which a pixel is flare; default: the cut calibrated for the
    weights (their threshold metadata, written by `deflare-scene fmg calibrate`), else 0.5."""
    work_size: int = option(512, ge=32)
    """Long side (pixels) at which the FMG runs."""
    scales: tuple[float, ...] = option((1.0,), gt=0, le=2, metavar="S1,S2")
    """Fractions of ``work_size`` at which the FMG runs, its probabilities averaged over them
    before the cut (PSPNet's multi-scale testing; e.g. 1,0.75 runs it at 512 and 384 px,
    about 1.6 times the pixels to run). The flare rays are found at ``work_size`` alone
    (docs/history/fmg.md, "Thirty-first session")."""
    pads: tuple[str, ...] = option(("reflect", "replicate", "constant"),
                                   choices=("reflect", "replicate", "constant"))
    """The network run again on each view padded at every edge (3 % of the long side) in
    each of these ways (comma-separated: reflect, replicate, constant; none: the plain pass
    alone, the default before the seventy-third session): what the network marks on clean
    photos moves with the padding, flare does not (docs/history/fmg.md, "Seventy-second
    session"). One more network pass per padding."""
    pads_keep: str = option("pixels", choices=("pixels", "regions"))
    """With ``pads``: what the passes' agreement keeps. pixels (the default since the
    seventy-third session): each pixel at its lowest probability over the passes; regions:
    each region of the plain pass's marks whole where the padded passes agree on some pixel
    of it (more of the marks kept, false ones too). Either way the plain pass runs once."""
    refine: bool = False
    """Refine the probability map with a guided filter on the image before thresholding."""
    rays: bool = True
    """Also mark flare rays, starburst spikes and streaks running straight out of a
    saturated light (``pipeline.flare_rays``), found at ``work_size`` and added to the
    FMG's mask. On by default since the fifth session (a light must send out three
    separate rays, which removed the rays' false marks on the daylight development
    scenes); ``--no-rays`` for the FMG alone (docs/history/fmg.md, "Fifth session").
    """
    ray_min: int | None = option(None, ge=1)
    """Fewest separate rays a light must send out for its rays to be marked (default: the
    rule's, 3). Night photos with long lamp streaks (one or two rays per lamp): 1, or keep
    3 and give ``ray_opposite``; both mark more scene lines on daylight photos."""
    ray_opposite: float | None = option(None, ge=0, le=90)
    """Degrees within which two rays leaving a light in opposite directions (a streak
    through it) also count as enough (default: the rule's, 0 = off)."""
    streak_lines: bool | None = option(None, flag="--streak-lines/--no-streak-lines")
    """With the rays: also mark thin straight streaks through a light, one each way
    (``pipeline.flare_lines``; an anamorphic lens's streak), which the rays' polar runs
    lose. Default (unset): the ray rule's (off)."""
    streak_scales: tuple[float, ...] | None = option(None, gt=0, le=1, metavar="S1,S2")
    """With ``streak_lines``: also look for the streaks on the photo shrunk to these
    fractions of the working size, e.g. 1,0.25: a beam tens of pixels wide through a night
    lamp is a thin ridge at a quarter. An option, not judged as the default
    (docs/history/fmg.md, "Ninety-sixth session"). Default (unset): 1 alone."""
    light_cores: bool | None = option(None, flag="--light-cores/--no-light-cores")
    """Also find a lamp whose saturated streak runs out of it (its saturated region too long
    or ragged to be a light) by the region's core, for the rays and the ghost lines; such a
    light's rays are kept when two leave it in opposite directions (a streak through it;
    ``pipeline.flare_rays.RayConfig.cores``). Default (unset): the ray rule's (off)."""
    ghost_lines: bool | None = option(None, flag="--ghost-lines/--no-ghost-lines")
    """Also mark the FMG's weak regions (probability above 0.25, under the cut) on the line
    through a saturated light and the image centre, where a lens's ghosts lie
    (``pipeline.flare_ghosts``): two or more on one line, or each one the other photos
    confirm (``ghost_views``). Default (unset): on, except with hand-made ``--masks``; on
    since the thirty-fifth session with ``ghost_views`` (docs/history/fmg.md, "Thirty-third
    session" to "Thirty-fifth session": what it gains on ghosts, costs on clean photos)."""
    ghost_chain: int | None = option(None, ge=1)
    """With ``ghost_lines``: fewest weak regions on one light's line for them to be marked
    (default: the rule's, 2, or 1 with ``ghost_views``; 1 finds more ghosts and, alone,
    marks more of clean photos)."""
    ghost_views: bool | None = option(None, flag="--ghost-views/--no-ghost-views")
    """With ``ghost_lines``: let the neighbouring photos judge each weak region on a light's
    line (one is enough, ``ghost_chain`` 1), after depth from the photos: it is marked only
    when at least 0.3 of the pixels two neighbours agree on are brighter than they see the
    scene there, by the mask rule (``pipeline.crosscheck.add_confirmed``); a region no
    neighbour can judge is not marked. The candidates are kept in ``WS/masks_ghosts/``, the
    network's masks in ``WS/masks_fmg/``. Needs at least 2 posed views; about as slow as
    ``crosscheck``, with which it shares the depth (+1.5 s a 504 px view on one CPU thread).
    Default (unset): on with ``ghost_lines`` where at least 2 views are posed
    (docs/history/fmg.md, "Thirty-fourth session" and "Thirty-fifth session")."""
    fill_holes: bool = False
    """Also mark the unmarked pixels an FMG mask encloses (the light's own core inside its
    flare, which the full-width candidate ``fmg_candidate_L.safetensors`` leaves out as its
    training masks do; use it with that file); off by default, the shipped file's masks
    have almost no holes (docs/history/fmg.md, "Seventeenth session"). Hand-made
    ``--masks`` are kept as given."""
    confirm: bool = False
    """Two networks confirm each other, region by region: keep a connected region of the
    FMG's mask where a second network (``confirm_weights``, at its own calibrated cut) marks
    at least one pixel, and (``confirm_keep`` both) a region of the second's where the FMG
    marks one; then add the flare rays and (both) mark what the result encloses. A flare
    both find keeps its extent; a mark only one makes (most false marks on clean photos,
    but also a ghost only one finds) is dropped (``confirmed_regions``). Off: on the
    development scenes it marks a third as much of clean photos and scores higher flare IoU,
    but gave de-flared photos 0.15-0.22 dB lower in the flare region (docs/history/fmg.md,
    "Eighteenth session")."""
    confirm_weights: Path | None = option(None, exists=True)
    """The second network of ``confirm``; default the full-width FMG,
    gnfr/weights/fmg_candidate_L.safetensors."""
    confirm_keep: str | None = option(None, choices=("both", "first"))
    """With ``confirm``: keep the confirmed regions of both networks (both, the default), or
    only the FMG's own regions that the second network confirms (first: a subset of the
    FMG's mask, then the rays; no holes are filled)."""
    crosscheck: bool = False
    """Let the neighbouring photos overrule the FMG: after its masks, depth from the photos
    and, per view, drop a marked region that the nearest views (warped through that depth,
    their own marks excluded) agree is scene no brighter than they see it
    (``pipeline.crosscheck``). The network's own masks are kept in ``WS/masks_fmg/``. Off:
    on the development scenes it removed a quarter of the marks on clean photos with flare
    IoU level, and the de-flared photos of flared scenes gained only 0.065 dB in the flare
    region (the default needs 0.10; docs/history/fmg.md, "Twenty-eighth session"). Needs
    at least 2 posed views; 2.2 s more per 504 px view on one CPU thread
    (``benchmarks/crosscheck_time.py``)."""
    batch: int = option(4, ge=1)
    """Views per FMG forward pass."""
    device: str = option("auto", device=True)
    """torch device for the FMG: auto (CUDA when present), cpu, cuda or cuda:N."""

    def rules(self) -> None:
        """The options that need another or exclude one (a one-line UserError), run by
        ``pipeline.options.validate`` after the fields' ranges, before anything is read or
        written; resolving the defaults is :func:`check_config`'s."""
        if self.ghost_views and self.masks_dir is not None:
            raise UserError("--ghost-views lets the other photos judge an FMG's weak marks: "
                            "it has no use with --masks (your masks are kept as given); leave "
                            "one out")
        if self.streak_lines and (not self.rays or self.masks_dir is not None):
            raise UserError("--streak-lines adds streaks to the FMG's flare rays: it has no "
                            "use with --no-rays or --masks; leave one out")
        check_streak_scales(self)
        lines = self.masks_dir is None if self.ghost_lines is None else self.ghost_lines
        ghost_config(replace(self, ghost_lines=lines))  # --ghost-chain without the lines
        if self.confirm_weights is not None and not self.confirm:
            raise UserError("--confirm-weights names the second network of --confirm: add "
                            "--confirm, or leave --confirm-weights out")
        if self.confirm_keep is not None and not self.confirm:
            raise UserError("--confirm-keep says which regions --confirm keeps: add "
                            "--confirm, or leave --confirm-keep out")
        if self.pads_keep != "pixels" and not self.pads:  # the default says nothing
            raise UserError("--pads-keep says what the padded runs of --pads keep, and --pads "
                            "is none: give --pads reflect,replicate,constant, or leave "
                            "--pads-keep out")
        for on, flag, what in (
                (self.confirm, "--confirm", "checks an FMG's marks with a second network"),
                (self.ghost_lines, "--ghost-lines", "adds to an FMG's marks"),
                (self.light_cores, "--light-cores", "finds lights for an FMG's rays and "
                 "ghost lines"),
                (self.crosscheck, "--crosscheck",
                 "checks an FMG's marks against the other photos")):
            if on and self.masks_dir is not None:
                raise UserError(f"{flag} {what}: it has no use with --masks (your masks are "
                                "kept as given); leave one out")


# --------------------------------------------------------------------------- weights
def weights_path(config: MaskConfig) -> Path:
    return Path(config.weights) if config.weights else DEFAULT_WEIGHTS


def weights_id(path: Path) -> str:
    """'<file name>@sha256:<first 16 hex>' identifying a weight file."""
    h = hashlib.sha256(path.read_bytes()).hexdigest()[:16]
    return f"{path.name}@sha256:{h}"


def resolve_threshold(config: MaskConfig, wpath: Path | None) -> float:
    """The probability cut to use: the config's, else the weights' calibrated one, else 0.5."""
    if config.threshold is not None:
        return float(config.threshold)
    if wpath is not None:
        from gnfr.fmg import read_fmg_metadata

        try:
            cut = read_fmg_metadata(wpath).get("threshold")
        except Exception:  # noqa: BLE001 - not a safetensors file: loading it says so
            cut = None
        if cut is not None:
            return float(cut)
    return 0.5


def load_fmg_weights(path: Path, device: str = "cpu", flag: str = "--weights"):
    """Load the FMG, turning a missing or foreign file into a UserError saying what to do
    (``flag``: the option that named the file)."""
    from gnfr.fmg import load_fmg

    how = ("train one with `deflare-scene fmg train --out FMG_RUN` and copy "
           f"FMG_RUN/fmg.safetensors to {DEFAULT_WEIGHTS}, or pass --weights PATH")
    if flag != "--weights":
        how = f"pass {flag} PATH (FMG weights, e.g. {DEFAULT_CONFIRM_WEIGHTS.name})"
    try:
        return load_fmg(path, device)
    except FileNotFoundError:
        raise UserError(f"FMG weights {path} are missing: {how}") from None
    except ValueError as e:
        raise UserError(f"FMG weights {path} cannot be used ({e}): {how}") from None


# --------------------------------------------------------------------------- FMG masks
def refine_probs(image_bgr: np.ndarray, probs: np.ndarray, radius: int = 8,
                 eps: float = 1e-3) -> np.ndarray:
    """Guided-filter the probability map [H, W] with the image as guide (edge-following).

    The guide is the image's grey level: with a 3-channel guide the filter's 3x3 colour
    covariance is near-singular on grey-ish content and small ``eps`` breaks it.
    """
    guide = cv2.cvtColor(image_bgr, cv2.COLOR_BGR2GRAY).astype(np.float32) / 255.0
    out = cv2.ximgproc.guidedFilter(guide, probs.astype(np.float32), radius, eps)
    return np.clip(out, 0.0, 1.0)


def _batch_tensor(images_bgr: list[np.ndarray]):
    """[B, 3, H, W] float sRGB tensor in [0, 1] of same-size BGR uint8 images."""
    import torch

    x = np.stack([im[..., ::-1] for im in images_bgr]).astype(np.float32) / 255.0
    return torch.from_numpy(x).permute(0, 3, 1, 2)


def fmg_probs(model, images_bgr: list[np.ndarray], work_size: int,
              scales: tuple[float, ...] = (1.0,),
              pads: tuple[str, ...] = ()) -> list[np.ndarray]:
    """Flare probabilities [H, W] float32 for a batch of same-size BGR uint8 images, the
    network run at ``work_size`` times each of ``scales`` (averaged), with ``pads`` as
    ``MaskConfig.pads``."""
    from gnfr.fmg import predict_probs

    probs = predict_probs(model, _batch_tensor(images_bgr), work_size, scales,
                          tuple(pads))  # [B, 1, H, W]
    return list(probs[:, 0].cpu().numpy())


def network_maps(model, images_bgr: list[np.ndarray], work_size: int,
                 scales: tuple[float, ...] = (1.0,), pads: tuple[str, ...] = (),
                 keep: str = "pixels") -> tuple[list[np.ndarray], list]:
    """(probs, consensus) of each image, what ``flare_marks`` cuts: with ``pads`` and
    ``keep`` "regions" the plain run and the padded runs' agreement (``fmg_probs_pair``),
    else ``fmg_probs`` with ``pads`` and no consensus (None each)."""
    if pads and keep == "regions":
        return fmg_probs_pair(model, images_bgr, work_size, scales, pads)
    return fmg_probs(model, images_bgr, work_size, scales, pads), [None] * len(images_bgr)


def fmg_probs_pair(model, images_bgr: list[np.ndarray], work_size: int,
                   scales: tuple[float, ...], pads: tuple[str, ...]
                   ) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """(plain, agreed): ``fmg_probs`` without ``pads`` and with them, the plain pass run
    once (`mask --pads-keep regions`)."""
    from gnfr.fmg import predict_probs_pair

    pair = predict_probs_pair(model, _batch_tensor(images_bgr), work_size, scales,
                              tuple(pads))
    return list(pair[0][:, 0].cpu().numpy()), list(pair[1][:, 0].cpu().numpy())


def lights_at_work_size(image_bgr: np.ndarray, work_size: int, ray_cfg=None) -> tuple:
    """(sRGB float image at long side ``work_size``, its scale, its lights): what the flare
    rays and the ghost lines both start from (``pipeline.flare_rays.find_lights`` with
    ``ray_cfg``, default its RayConfig; of the mask options only ``light_cores`` changes
    it), for ``ray_marks`` and ``ghost_marks``' ``found``."""
    from pipeline.flare_rays import RayConfig, find_lights

    small, s = _at_work_size(image_bgr, work_size)
    rgb = small[..., ::-1].astype(np.float32) / 255.0
    return rgb, s, find_lights(rgb, ray_cfg or RayConfig())


def ray_marks(image_bgr: np.ndarray, work_size: int, ray_cfg=None,
              found: tuple | None = None) -> np.ndarray:
    """[H, W] bool flare rays (``pipeline.flare_rays.ray_mask`` with ``ray_cfg``, default
    its RayConfig) of a BGR uint8 image, found at long side ``work_size`` (never upscaled)
    and brought back to the image's size; ``found``: ``lights_at_work_size`` if known."""
    from pipeline.flare_rays import ray_mask

    h, w = image_bgr.shape[:2]
    if found is None:
        small, s = _at_work_size(image_bgr, work_size)
        marks = ray_mask(small[..., ::-1].astype(np.float32) / 255.0, ray_cfg)
    else:
        rgb, s, lights = found
        marks = ray_mask(rgb, ray_cfg, lights)
    if s == 1.0:
        return marks
    return cv2.resize(marks.astype(np.uint8), (w, h), interpolation=cv2.INTER_NEAREST) > 0


def ghost_marks(image_bgr: np.ndarray, probs: np.ndarray, work_size: int,
                ghost_cfg=None, found: tuple | None = None) -> np.ndarray:
    """[H, W] bool ghost-line regions (``pipeline.flare_ghosts.ghost_line_mask``, rule
    ``ghost_cfg``) of the FMG probabilities ``probs`` [H, W] of a BGR uint8 image, its
    lights found at long side ``work_size`` as the flare rays find them (``found``:
    ``lights_at_work_size`` if known)."""
    from pipeline.flare_ghosts import ghost_line_mask

    _, s, lights = found if found is not None else lights_at_work_size(image_bgr, work_size)
    return ghost_line_mask(probs, [(x / s, y / s, r / s) for x, y, r in lights],
                           cfg=ghost_cfg)


def _at_work_size(image_bgr: np.ndarray, work_size: int) -> tuple[np.ndarray, float]:
    """The image shrunk (area) to long side ``work_size`` (never enlarged), and the scale."""
    h, w = image_bgr.shape[:2]
    s = min(1.0, work_size / max(h, w))
    if s == 1.0:
        return image_bgr, s
    return cv2.resize(image_bgr, (max(1, round(w * s)), max(1, round(h * s))),
                      interpolation=cv2.INTER_AREA), s


def flare_marks(model, image_bgr: np.ndarray, cut: float, work_size: int,
                rays: bool = False, refine: bool = False,
                probs: np.ndarray | None = None, ray_cfg=None, confirm=None,
                confirm_probs: np.ndarray | None = None,
                scales: tuple[float, ...] = (1.0,), ghosts=None,
                found: tuple | None = None, pads: tuple[str, ...] = (),
                consensus: np.ndarray | None = None, pads_keep: str = "pixels") -> np.ndarray:
    """[H, W] bool flare mask of one BGR uint8 image: the FMG's probabilities (``probs`` if
    already computed) refined if asked, cut at ``cut``, with the flare rays (``ray_cfg``) if
    ``rays`` and the ghost-line regions of the probabilities (``ghost_marks``) if
    ``ghosts`` (a ``pipeline.flare_ghosts.GhostConfig``). With ``confirm`` = (second
    model, its cut, keep) the mask of `mask --confirm` (``confirmed_marks``; the second's
    probabilities ``confirm_probs`` if already computed). ``scales``: as
    ``MaskConfig.scales`` (the rays are found at ``work_size``), ``pads`` as
    ``MaskConfig.pads``; ``found``: ``lights_at_work_size`` if already known. With
    ``consensus`` (the probabilities with ``pads``, `mask --pads-keep regions`) the network's
    marks are the regions of ``probs`` over the cut that hold a pixel of ``consensus`` over
    it (``regions_touching``), before the ghost lines and the rays are added; with neither
    given, ``pads_keep`` as ``MaskConfig.pads_keep`` (``network_maps``)."""

    def network_probs(m, p):
        p = fmg_probs(m, [image_bgr], work_size, scales, pads)[0] if p is None else p
        return refine_probs(image_bgr, p) if refine else p

    if probs is None and consensus is None:
        maps = network_maps(model, [image_bgr], work_size, scales, pads, pads_keep)
        probs, consensus = maps[0][0], maps[1][0]
    p_main = network_probs(model, probs)
    marks = p_main > cut
    if consensus is not None:
        marks = regions_touching(marks, consensus > cut)
    if ghosts is not None:
        if found is None:  # the rays start from the same lights
            found = lights_at_work_size(image_bgr, work_size, ray_cfg)
        marks |= ghost_marks(image_bgr, p_main, work_size, ghosts, found)
    rayed = ray_marks(image_bgr, work_size, ray_cfg, found) if rays else None
    if confirm is not None:
        second, second_cut, keep = confirm
        return confirmed_marks(marks, network_probs(second, confirm_probs) > second_cut,
                               keep, rayed)
    return marks if rayed is None else marks | rayed


def regions_touching(marks: np.ndarray, seeds: np.ndarray) -> np.ndarray:
    """The 8-connected regions of ``marks`` [H, W] bool that hold a pixel of ``seeds``."""
    n, labels = cv2.connectedComponents(marks.astype(np.uint8), connectivity=8)
    keep = np.zeros(n, bool)
    keep[np.unique(labels[seeds & marks])] = True
    keep[0] = False
    return keep[labels]


def confirmed_marks(first: np.ndarray, second: np.ndarray, keep: str,
                    extra: np.ndarray | None = None) -> np.ndarray:
    """`mask --confirm`'s mask from two networks' cut masks [H, W] bool:
    ``confirmed_regions(first, second, keep)``, then ``extra`` (the flare rays) added, then
    with ``keep`` "both" the enclosed holes filled."""
    marks = confirmed_regions(first, second, keep)
    if extra is not None:
        marks |= extra
    return marks | enclosed_holes(marks) if keep == "both" else marks


def confirmed_regions(a: np.ndarray, b: np.ndarray, keep: str = "both") -> np.ndarray:
    """[H, W] bool: the 8-connected regions of ``a`` that share a pixel with ``b`` and (with
    ``keep`` "both") those of ``b`` that share one with ``a`` (two masks confirming each
    other's regions: a region both find keeps the extent of both, a region only one finds is
    dropped); with ``keep`` "first" only ``a``'s confirmed regions (a subset of ``a``)."""
    out = np.zeros(a.shape, bool)
    for m, other in ((a, b), (b, a))[:2 if keep == "both" else 1]:
        n, labels = cv2.connectedComponents(m.astype(np.uint8), connectivity=8)
        if n > 1:
            hit = np.zeros(n, bool)
            hit[np.unique(labels[other & m])] = True
            hit[0] = False
            out |= hit[labels]
    return out


def check_streak_scales(config) -> None:
    """A one-line UserError when ``config`` (the mask stage's, `fmg eval`'s or `fmg
    overlay`'s) gives ``streak_scales`` without ``streak_lines``: they would change nothing."""
    if config.streak_scales is not None and not config.streak_lines:
        raise UserError("--streak-scales sets where --streak-lines looks: add "
                        "--streak-lines, or leave --streak-scales out")


def parse_streak_scales(text: str) -> tuple[float, ...]:
    """The command-line ``--streak-scales`` text (e.g. ``1,0.25``) as the mask stage's option
    reads and checks it (numbers, each over 0 and at most 1); else a one-line UserError."""
    import typing

    from pipeline.options import check_field, coerce

    tp = typing.get_type_hints(MaskConfig)["streak_scales"]
    scales = coerce(text, tp, f"--streak-scales {text}")
    if scales is None:  # "none" unsets the stage's option; a script asking for scales needs them
        raise UserError(f"--streak-scales {text}: give fractions of the size, e.g. 1,0.25")
    check_field(MaskConfig(streak_lines=True, streak_scales=scales), "streak_scales")
    return scales


def ray_config(config: MaskConfig):
    """The flare-ray rule of the mask stage (or of any config with ``ray_min``,
    ``ray_opposite``, ``streak_lines``, ``streak_scales`` and ``light_cores``, e.g. `fmg
    eval`'s): RayConfig's defaults with those where given."""
    from pipeline.flare_rays import RayConfig

    over = {k: v for k, v in (("min_rays", config.ray_min), ("opposite", config.ray_opposite),
                              ("lines", config.streak_lines), ("cores", config.light_cores),
                              ("line_scales", config.streak_scales))
            if v is not None}
    return RayConfig(**over)


def ghost_config(config: MaskConfig):
    """The ghost-line rule (``pipeline.flare_ghosts.GhostConfig``) of the mask stage (or of
    any config with ``ghost_lines`` and ``ghost_chain``, e.g. `fmg eval`'s) when
    ``ghost_lines``, else None; ``ghost_chain`` without it is a one-line UserError.
    ``ghost_views`` (the mask stage's alone: `fmg eval` scores single photos, which no
    other view can judge) makes the chain's default 1."""
    views = getattr(config, "ghost_views", False)
    if not config.ghost_lines:
        for value, flag in ((config.ghost_chain, "--ghost-chain"),
                            (views or None, "--ghost-views")):
            if value is not None:
                raise UserError(f"{flag} sets the ghost lines' rule: add --ghost-lines")
        return None
    from pipeline.flare_ghosts import GhostConfig

    chain = config.ghost_chain
    if chain is None:
        chain = 1 if views else GhostConfig().min_chain
    return GhostConfig(min_chain=chain)


def _batches(stems: list[str], sizes: dict[str, tuple[int, int]], n: int):
    """Group stems of one image size into batches of at most n."""
    by_size: dict[tuple[int, int], list[str]] = {}
    for s in stems:
        by_size.setdefault(sizes[s], []).append(s)
    for group in by_size.values():
        for i in range(0, len(group), n):
            yield group[i:i + n]


def write_fmg_masks(model, config: MaskConfig, ws: Workspace, stems: list[str],
                    confirm=None) -> None:
    """Run the FMG ``model`` (``load_fmg_weights``) on the views in ``stems`` and write
    their masks; ``confirm`` = (second model, its cut, keep) for ``config.confirm``."""
    import torch

    sizes = {s: image_size(ws.image_path(s), fix=ws.rerun("pose")) for s in stems}
    batches = list(_batches(stems, sizes, config.batch))
    rule = ray_config(config)
    ghosts = ghost_config(config)
    judged_later = config.ghost_views  # the candidates wait for the other photos' judgement
    with torch.inference_mode():
        for batch in track(batches, "FMG masks (batches)"):
            imgs = [read_view_image(ws, s, bgr=True) for s in batch]
            probs, agreed = network_maps(model, imgs, config.work_size, config.scales,
                                         config.pads, config.pads_keep)
            second = (fmg_probs(confirm[0], imgs, config.work_size, config.scales,
                                config.pads)
                      if confirm is not None else [None] * len(imgs))
            for s, img, p, q, c in zip(batch, imgs, probs, second, agreed, strict=True):
                found = lights_at_work_size(img, config.work_size, rule) if ghosts else None
                m = flare_marks(model, img, config.threshold, config.work_size, config.rays,
                                config.refine, probs=p, ray_cfg=rule, confirm=confirm,
                                confirm_probs=q, ghosts=None if judged_later else ghosts,
                                found=found, consensus=c)
                if config.fill_holes:
                    m |= enclosed_holes(m)
                if judged_later:  # written before the mask: a mask's candidates exist
                    pg = refine_probs(img, p) if config.refine else p
                    write_mask_file(ws.root / GHOST_CANDIDATES_DIR / f"{s}.png",
                                    ghost_marks(img, pg, config.work_size, ghosts, found) & ~m)
                write_mask(ws, s, m)


# --------------------------------------------------------------------------- given masks
def find_given_mask(masks_dir: Path, stem: str, images: list[Path]) -> Path:
    """The mask of view ``stem`` among ``images`` (the image files of ``masks_dir``)."""
    hits = [p for p in images if p.stem == stem]
    if not hits:
        near = [p.name for p in images if stem in p.stem][:3]  # e.g. DSC_1_mask.png
        named = (f" ({', '.join(near)} {'is' if len(near) == 1 else 'are'} not named after "
                 "the view alone)") if near else ""
        raise UserError(f"--masks {masks_dir} has no mask for view '{stem}'{named}: add "
                        f"{masks_dir / (stem + '.png')} (nonzero = flare)")
    return hits[0]


def given_masks(masks_dir: Path, stems: list[str]) -> dict[str, Path]:
    """{stem: the hand-made mask file of each view} of ``--masks DIR``; a one-line error
    naming the first view without one (or a DIR that is not a folder)."""
    if not masks_dir.is_dir():
        raise UserError(f"--masks {masks_dir} is not a folder of mask images")
    images = sorted(p for p in masks_dir.iterdir() if is_photo(p))  # listed once
    return {s: find_given_mask(masks_dir, s, images) for s in stems}


def write_given_masks(srcs: dict[str, Path], ws: Workspace, stems: list[str]) -> None:
    """Copy the hand-made masks ``srcs`` (:func:`given_masks`; nonzero = flare) of
    ``stems``, resized (nearest) to each image's size."""
    for s in track(stems, "copying masks"):
        # the user's file as it is (any depth, alpha): nonzero in any channel is flare
        m = read_image_as_stored(srcs[s], fix="save the mask as PNG/JPEG")
        if m.ndim == 3:
            m = m.max(axis=2)
        h, w = image_size(ws.image_path(s), fix=ws.rerun("pose"))
        write_mask(ws, s, cv2.resize(m, (w, h), interpolation=cv2.INTER_NEAREST) > 0)


# --------------------------------------------------------------------------- helpers
def overview_sheet(tiles: list[tuple[str, np.ndarray, np.ndarray]], thumb: int = 320,
                   cols: int | None = None) -> np.ndarray:
    """A BGR contact sheet: each (stem, image BGR, mask bool) tinted red where flare."""
    cols = cols or min(len(tiles), max(1, math.ceil(math.sqrt(len(tiles)))), 6)
    rows = math.ceil(len(tiles) / cols)
    th = round(thumb * 3 / 4)
    sheet = np.full((rows * (th + 4), cols * (thumb + 4), 3), 32, np.uint8)
    for i, (stem, img, mask) in enumerate(tiles):
        s = min(thumb / img.shape[1], th / img.shape[0])
        w, h = max(1, round(img.shape[1] * s)), max(1, round(img.shape[0] * s))
        im = cv2.resize(img, (w, h), interpolation=cv2.INTER_AREA).astype(np.float32)
        m = cv2.resize(mask.astype(np.uint8), (w, h), interpolation=cv2.INTER_NEAREST) > 0
        im[m] = 0.45 * im[m] + 0.55 * np.array([0, 0, 255], np.float32)
        r, c = divmod(i, cols)
        y, x = r * (th + 4) + 2, c * (thumb + 4) + 2
        sheet[y:y + h, x:x + w] = im.astype(np.uint8)
        # the label spans the cell, not the image: a portrait photo's thumbnail is narrower
        put_label(sheet[y:y + th, x:x + thumb], f"{stem}  {100 * flare_fraction(mask):.1f}%")
    return sheet


# --------------------------------------------------------------------------- stage
def check_config(config: MaskConfig) -> MaskConfig:
    """``config`` checked (``validate``: its fields, then :meth:`MaskConfig.rules`) and
    returned with ``ghost_lines`` and ``confirm_keep`` resolved (``ghost_views`` is resolved
    by ``run``, which knows how many views are posed)."""
    validate(config)
    if config.ghost_lines is None:  # on by default where it has a use
        config = replace(config, ghost_lines=config.masks_dir is None)
    if config.confirm:
        config = replace(config, confirm_keep=config.confirm_keep or "both")
    return config


def run(config: MaskConfig, ws: Workspace, force: bool = False) -> list[Path]:
    """Write WS/masks, WS/flare.json and WS/masks_overview.jpg; returns the written paths."""
    config = check_config(config)
    ws.require("pose")
    stems = view_stems(ws)
    if config.ghost_views is None:  # on by default with the ghost lines where views can judge
        config = replace(config, ghost_views=bool(config.ghost_lines) and len(stems) >= 2)
    for on, flag in ((config.crosscheck, "--crosscheck"), (config.ghost_views, "--ghost-views")):
        if on and len(stems) < 2:
            raise UserError(f"{flag} compares each view with the others, and {ws.root} has "
                            f"{len(stems)} posed view(s): leave {flag} out")
    confirm = None
    given: dict[str, Path] = {}
    if config.masks_dir is not None:
        masks_dir = Path(config.masks_dir).resolve()
        # every view's mask found before the stage touches the workspace (an earlier run's
        # masks stay when one is missing), as a missing weights file does below
        given = given_masks(masks_dir, stems)
        source, wid, inputs = f"masks:{masks_dir}", None, [ws.images, masks_dir]
        model = None
    else:
        wpath = weights_path(config)
        # a missing or foreign file fails here, before the stage touches the workspace (the
        # masks of an earlier run stay); the UserError says how to get weights
        model = load_fmg_weights(wpath, resolve_device(config.device))
        source, wid, inputs = "fmg", weights_id(wpath), [ws.images, wpath]
        config = replace(config, threshold=resolve_threshold(config, wpath))
        if config.confirm:
            cpath = Path(config.confirm_weights or DEFAULT_CONFIRM_WEIGHTS)
            confirm = (load_fmg_weights(cpath, resolve_device(config.device),
                                        "--confirm-weights"),
                       resolve_threshold(MaskConfig(), cpath), config.confirm_keep)
            inputs.append(cpath)
        if config.crosscheck or config.ghost_views:
            inputs.append(ws.cameras_json)
    params = {k: str(v) if isinstance(v, Path) else v for k, v in asdict(config).items()
              if k not in ("device", "batch")}
    params["source"], params["weights"] = source, wid
    if confirm is not None:
        params["confirm_weights"], params["confirm_cut"] = weights_id(cpath), confirm[1]
    stage_run = ws.begin_stage("mask", params, inputs, force, defaults=asdict(MaskConfig()))
    if stage_run.skip:
        info(f"mask: up to date ({ws.flare_json})")
        return stage_run.outputs
    ws.masks.mkdir(parents=True, exist_ok=True)
    resumed = ws.resumable(stage_run)
    for p in ws.masks.glob("*.png"):  # masks of views that no longer exist, or stale ones
        if p.stem not in stems or not resumed:
            p.unlink()
    views_pass = config.crosscheck or config.ghost_views
    for d in (FMG_MASKS_DIR, GHOST_CANDIDATES_DIR):
        if (ws.root / d).is_dir() and not (views_pass and resumed):
            shutil.rmtree(ws.root / d)  # an earlier run's: stale now
    if config.ghost_views:
        (ws.root / GHOST_CANDIDATES_DIR).mkdir(exist_ok=True)
    todo = [s for s in stems if not ws.mask_path(s).exists()]
    if todo and config.masks_dir is not None:
        write_given_masks(given, ws, todo)
    elif todo:
        write_fmg_masks(model, config, ws, todo, confirm)
    if views_pass:
        crosscheck_masks(ws, stems, drop=config.crosscheck, ghosts=config.ghost_views)
    return _summarise(config, ws, stage_run, stems, source, wid)


FMG_MASKS_DIR = "masks_fmg"
"""``WS/masks_fmg/<stem>.png``: with ``--crosscheck`` or ``--ghost-views``, the network's
masks before the other photos judged them (same format as WS/masks)."""
GHOST_CANDIDATES_DIR = "masks_ghosts"
"""``WS/masks_ghosts/<stem>.png``: with ``--ghost-views``, the ghost-line regions the
network's masks leave out, before the other photos judged them (same format)."""


def crosscheck_masks(ws: Workspace, stems: list[str], drop: bool = True,
                     ghosts: bool = False) -> None:
    """`mask --crosscheck` (``drop``) and `--ghost-views` (``ghosts``): keep the FMG's masks
    in WS/masks_fmg (all of them before any is changed, so an interrupted run resumes from
    them) and write to WS/masks the ones the other photos judged (``pipeline.crosscheck``):
    without the marks they see as scene (``drop``), with the ghost-line candidates of
    WS/masks_ghosts they see as flare (``ghosts``)."""
    from pipeline.crosscheck import crosscheck

    fmg_dir = ws.root / FMG_MASKS_DIR
    if not all((fmg_dir / f"{s}.png").exists() for s in stems):
        fmg_dir.mkdir(exist_ok=True)
        for s in stems:
            if not (fmg_dir / f"{s}.png").exists():
                atomic_write_bytes(fmg_dir / f"{s}.png", ws.mask_path(s).read_bytes())
    fmg = {s: read_mask_file(fmg_dir / f"{s}.png", ws.rerun("mask")) for s in stems}
    cands = None
    if ghosts:
        cands = {s: read_mask_file(ws.root / GHOST_CANDIDATES_DIR / f"{s}.png",
                                   ws.rerun("mask")) for s in stems}
    checked = crosscheck(ws, fmg, candidates=cands, drop=drop)
    for s in stems:
        write_mask(ws, s, checked[s])
    before = sum(int(m.sum()) for m in fmg.values())
    dropped = sum(int((fmg[s] & ~checked[s]).sum()) for s in stems)
    added = sum(int((checked[s] & ~fmg[s]).sum()) for s in stems)
    said = [f"dropped {100 * dropped / max(before, 1):.1f}% of the marked pixels as scene"
            " they agree on"] if drop else []
    if ghosts:
        offered = sum(int(m.sum()) for m in cands.values())
        if not offered and not drop:
            info("mask: no ghost-line candidates in any view: nothing for the other photos to "
                 "confirm")
            return
        said.append(f"confirmed {100 * added / max(offered, 1):.1f}% of the ghost-line "
                    "candidates as flare")
    info(f"mask: the other photos {' and '.join(said)}; the network's own masks: {fmg_dir}")


def _summarise(config: MaskConfig, ws: Workspace, stage_run, stems: list[str], source: str,
               wid: str | None) -> list[Path]:
    flare, tiles = FlareFile(source, config.threshold, wid), []
    src = "fmg" if source == "fmg" else "masks"
    for s in stems:
        m = read_mask(ws, s)
        flare.views[s] = FlareEntry(round(flare_fraction(m), 6), src)
        tiles.append((s, read_view_image(ws, s, bgr=True), m))
    write_flare(ws, flare)
    atomic_imwrite(ws.masks_overview, overview_sheet(tiles), [cv2.IMWRITE_JPEG_QUALITY, 90])
    frac = flare.fractions()
    worst = max(frac, key=lambda s: frac[s])
    info(f"mask: {len(stems)} views, most flared {worst} "
         f"({100 * frac[worst]:.1f}%); see {ws.masks_overview}")
    return stage_run.finish([ws.masks, ws.flare_json, ws.masks_overview],
                       extra={"views": len(stems)},
                       versions=["torch", "opencv-contrib-python-headless"])


def stage_seconds(ws: Workspace) -> float:
    """Seconds the last mask run took (from the manifest)."""
    return float(ws.stage_record("mask").get("seconds", math.nan))


__all__ = ["DEFAULT_WEIGHTS", "MaskConfig", "run", "check_config", "flare_fraction", "read_mask",
           "load_fmg_weights", "overview_sheet", "refine_probs", "fmg_probs", "weights_id",
           "flare_marks", "ray_config", "ray_marks", "ghost_config", "ghost_marks",
           "lights_at_work_size",
           "confirmed_regions", "confirmed_marks",
           "DEFAULT_CONFIRM_WEIGHTS"]
# flare_fraction and read_mask live in pipeline/ws_files.py (the workspace contract)
