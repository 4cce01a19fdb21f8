"""A synth scene folder as eval reads it: its views, ground-truth cameras, clean images, masks."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pipeline.cameras import Cameras, load_cameras
from pipeline.errors import UserError, shell_path
from pipeline.images import PHOTO_EXTS
from pipeline.workspace import Workspace, read_json
from pipeline.ws_files import read_mask_file


@dataclass
class SynthScene:
    root: Path
    cams: Cameras
    """Ground-truth cameras of every view."""
    train: list[str]
    heldout: list[str]
    origin: str
    """Name of the photo folder the clean scene came from (e.g. kermit)."""


def load_synth(root: Path) -> SynthScene:
    """Read and check a synth output folder."""
    root = Path(root).resolve()
    for name in ("photos", "clean", "masks_gt", "cameras_gt.json", "split.json"):
        if not (root / name).exists():
            raise UserError(f"{root / name} is missing: SCENE must be a folder written by "
                            "`deflare-scene synth WS --out SCENE`")
    split = read_json(root / "split.json")
    cams = load_cameras(root / "cameras_gt.json")
    train, held = list(split.get("train", [])), list(split.get("heldout", []))
    for s in train:
        if photo_path(root, s) is None:
            raise UserError(f"{root / 'photos' / (s + '.png')} is missing: rerun "
                            f"`deflare-scene synth ... --out {shell_path(root)} --force`")
    for s in train + held:
        if not (root / "clean" / f"{s}.png").is_file() or s not in cams.by_stem():
            raise UserError(f"{root}: view {s} has no clean image or camera: rerun synth")
    return SynthScene(root, cams, train, held, scene_origin(root))


def scene_origin(root: Path) -> str:
    """The photo folder name of the clean scene synth read (``origin`` in split.json, else
    the synth manifest, else the folder's own name)."""
    origin = read_json(root / "split.json").get("origin")
    if origin:
        return str(origin)
    try:
        ws = Path(Workspace(root).stage_record("synth")["params"]["workspace"])
        return Workspace(ws).scene_name if ws.exists() else ws.name
    except (KeyError, TypeError, UserError):
        return root.name



def photo_path(root: Path, stem: str, folder: str = "photos") -> Path | None:
    """The flared photo of ``stem`` in ``root/photos`` (synth writes PNG; the shipped sample
    keeps its photos as JPEG), or in ``root/<folder>`` (``clean``), or None."""
    for ext in PHOTO_EXTS:
        if (root / folder / f"{stem}{ext}").is_file():
            return root / folder / f"{stem}{ext}"
    return None



def truth_mask(scene: SynthScene, stem: str,
               shape: tuple[int, int] | None = None) -> np.ndarray:
    """[H, W] bool ground-truth flare mask SCENE/masks_gt/<stem>.png; at ``shape`` (h, w)
    when given, the pixels at least half covered by it (area resizing: a render smaller than
    the photos, e.g. the novel frames at the photos' own cameras, scored inside the flare)."""
    mask = read_mask_file(scene.root / "masks_gt" / f"{stem}.png",
                          f"rerun `deflare-scene synth ... --out {scene.root} --force`")
    if shape is None or mask.shape == tuple(shape):
        return mask
    import cv2

    return cv2.resize(mask.astype(np.float32), (shape[1], shape[0]),
                      interpolation=cv2.INTER_AREA) >= 0.5



def truth_mask_at(scene: SynthScene, stem: str, scale: float) -> np.ndarray:
    """[H, W] bool: the view's true flare by the mask rule with both thresholds (absolute and
    relative to the background) times ``scale``: ``scale`` 1 is about ``masks_gt`` (the
    flare read back from the 8-bit photos as flared minus clean in linear light, so a pixel
    or two at the edges differ), above 1 the flare's faint outer part is left unmarked. The
    light's core is in both images, so it is never flare here either."""
    return truth_masks_at(scene, stem, (scale,))[scale]


def truth_masks_at(scene: SynthScene, stem: str, scales) -> dict[float, np.ndarray]:
    """{scale: :func:`truth_mask_at`} for several scales, the view's two images read and the
    background smoothed once: the rule's threshold ``max(abs, rel x background)`` with both
    thresholds times ``scale`` is ``scale`` times the rule's own."""
    from pipeline.colour import srgb_to_linear
    from pipeline.flare import FlareConfig, luminance, mask_threshold
    from pipeline.images import read_image_float

    p = photo_path(scene.root, stem)
    if p is None:
        raise UserError(f"{scene.root / 'photos'} has no photo of {stem}: a training view "
                        "is needed")
    lin = [srgb_to_linear(read_image_float(f))
           for f in (p, scene.root / "clean" / f"{stem}.png")]
    flare = luminance(np.clip(lin[0] - lin[1], 0, None))
    thr = mask_threshold(FlareConfig(), flare.shape[:2], lin[1])
    return {scale: flare > np.float32(scale) * thr for scale in scales}


def flared_views(scene: SynthScene) -> list[str]:
    """Training views with flare in masks_gt (a clean view's input is its ground truth:
    scoring it would only add capped PSNRs)."""
    return [s for s in scene.train if truth_mask(scene, s).any()]

