"""Typed readers and writers of the workspace files: the one place their formats live.

Paths come from ``pipeline.workspace.Workspace`` (one property per file or folder); this
module reads and writes what is in them (docs/design.md, "The workspace contract"):

- ``WS/cameras.json``: ``Cameras`` / ``Frame`` (``pipeline/cameras.py``), ``read_cameras``,
  ``write_cameras``;
- ``WS/decoded/<stem>.png``: ``read_decoded``;
- ``WS/images/<stem>.png``: ``view_stems``, ``read_view_image``;
- ``WS/masks/<stem>.png``: 255 = flare; ``read_mask`` / ``read_masks`` (a pixel is flare
  above ``MASK_THRESHOLD``), ``write_mask``, ``has_masks``, ``flare_fraction``;
- ``WS/depth/<stem>.npz``: ``read_depth``, ``write_depth``;
- ``WS/flare.json``: ``FlareFile`` (``read_flare``, ``write_flare``);
- ``WS/views.json``: ``ViewsFile`` (``read_views``, ``write_views``, ``make_views``), whose
  ``targets`` and ``sources`` are the one rule of which views train and which serve;
- ``WS/manifest.json``: ``Workspace.begin_stage`` / ``record_stage`` (pipeline/workspace.py).

A missing or unreadable file is a one-line ``UserError`` naming it and the stage to rerun.
JSON files are written with ``atomic_write_json`` (indent 2, keys in the order below), so
a file read and written back is byte for byte the same.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gnfr.view_sampler import is_target
from pipeline.cameras import Cameras, Frame, load_cameras, save_cameras
from pipeline.errors import UserError, shell_path
from pipeline.images import read_gray, read_image, read_image_float
from pipeline.workspace import Workspace, atomic_imwrite, atomic_path, atomic_write_json, read_json

__all__ = [
    "MASK_THRESHOLD", "Cameras", "Frame", "read_cameras", "write_cameras", "read_decoded",
    "view_stems", "read_view_image", "read_mask_file", "read_mask", "read_masks", "write_mask",
    "write_mask_file", "grow_mask",
    "has_masks", "flare_fraction", "read_depth", "write_depth", "FlareEntry", "FlareFile",
    "read_flare", "write_flare", "SourceEntry", "ViewEntry", "ViewsFile", "is_target",
    "rank_sources", "make_views", "read_views", "write_views",
]


# --------------------------------------------------------------------------- cameras.json
def read_cameras(ws: Workspace) -> Cameras:
    """WS/cameras.json (a one-line error when missing or malformed)."""
    return load_cameras(ws.cameras_json)


def write_cameras(ws: Workspace, cams: Cameras) -> Path:
    return save_cameras(ws.cameras_json, cams)


# --------------------------------------------------------------------------- images
def read_decoded(ws: Workspace, stem: str) -> np.ndarray:
    """WS/decoded/<stem>.png as [H, W, 3] uint8 RGB."""
    return read_image(ws.decoded_path(stem), fix=ws.rerun("decode"))


def view_stems(ws: Workspace) -> list[str]:
    """Stems of WS/images/*.png, sorted; a UserError when there are none."""
    stems = sorted(p.stem for p in ws.images.glob("*.png")) if ws.images.is_dir() else []
    if not stems:
        raise UserError(f"{ws.images} has no images: run "
                        f"`deflare-scene pose {shell_path(ws.root)}` first")
    return stems


def read_view_image(ws: Workspace, stem: str, *, bgr: bool = False,
                    as_float: bool = False) -> np.ndarray:
    """WS/images/<stem>.png as [H, W, 3] uint8 RGB (BGR with ``bgr``; float32 RGB in [0, 1]
    with ``as_float``)."""
    path, fix = ws.image_path(stem), ws.rerun("pose")
    if as_float:
        return read_image_float(path, fix=fix)
    return read_image(path, bgr=bgr, fix=fix)


# --------------------------------------------------------------------------- masks
MASK_THRESHOLD = 127
"""A mask pixel is flare where its grey level is above this. WS/masks holds 0 and 255 only
(the mask stage writes them so); ground-truth masks (synth's masks_gt) use the same cut."""


def grow_mask(mask: np.ndarray, share: float) -> np.ndarray:
    """[H, W] bool ``mask`` grown by a disc of radius round(``share`` x long side) pixels
    (unchanged when that is 0): the fine-tune's ``--train-grow`` and render's
    ``--source-grow``."""
    import cv2

    r = round(share * max(mask.shape))
    if r < 1 or not mask.any():
        return mask
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
    return cv2.dilate(mask.astype(np.uint8), disc) > 0


def read_mask_file(path: str | os.PathLike, fix: str | None = None,
                   size: tuple[int, int] | None = None) -> np.ndarray:
    """[H, W] bool flare mask (grey level above ``MASK_THRESHOLD``) of a mask image,
    resized (nearest) to ``size`` (width, height) when given. A missing or unreadable file
    is a one-line UserError naming it; ``fix`` says what to do."""
    import cv2

    m = read_gray(path, fix=fix)
    if size is not None and (m.shape[1], m.shape[0]) != tuple(size):
        m = cv2.resize(m, tuple(size), interpolation=cv2.INTER_NEAREST)
    return m > MASK_THRESHOLD


def read_mask(ws: Workspace, stem: str, size: tuple[int, int] | None = None) -> np.ndarray:
    """[H, W] bool flare mask of WS/masks/<stem>.png (the geometry of WS/images/<stem>.png),
    resized (nearest) to ``size`` (width, height) when given."""
    return read_mask_file(ws.mask_path(stem), ws.rerun("mask"), size)


def has_masks(ws: Workspace, stems: Iterable[str]) -> bool:
    """True when WS/masks has a mask for every one of ``stems``."""
    return all(ws.mask_path(s).exists() for s in stems)


def read_masks(ws: Workspace, stems: Sequence[str],
               size: tuple[int, int] | None = None) -> dict[str, np.ndarray]:
    """{stem: [H, W] bool} of :func:`read_mask` for every stem (one error for the first
    missing or unreadable file)."""
    return {s: read_mask(ws, s, size) for s in stems}


def write_mask(ws: Workspace, stem: str, flare: np.ndarray) -> Path:
    """Write WS/masks/<stem>.png: 255 where ``flare`` (bool, or any nonzero value), else 0."""
    return write_mask_file(ws.mask_path(stem), flare)


def write_mask_file(path: Path, flare: np.ndarray) -> Path:
    """Write a mask image in WS/masks' format (255 where ``flare``, else 0), atomically."""
    return atomic_imwrite(path, np.where(flare, 255, 0).astype(np.uint8))


def flare_fraction(mask: np.ndarray) -> float:
    """Fraction of pixels marked flare in a [H, W] bool / uint8 mask."""
    return float(np.count_nonzero(mask)) / float(mask.size)


def enclosed_holes(mask: np.ndarray) -> np.ndarray:
    """[H, W] bool: unmasked pixels not connected to the image border through unmasked
    pixels (4-connectivity), i.e. holes the mask surrounds (the light at the centre of its
    flare, which the synth's true masks and a tight FMG mask leave unmarked)."""
    import cv2

    free = (~mask.astype(bool)).astype(np.uint8)
    _, labels = cv2.connectedComponents(free, connectivity=4)
    border = np.unique(np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]]))
    return (labels > 0) & ~np.isin(labels, border)


# --------------------------------------------------------------------------- depth
def read_depth(ws: Workspace, stem: str, path: Path | None = None
               ) -> tuple[np.ndarray, np.ndarray]:
    """(depth [H, W] float32, confidence [H, W]) of WS/depth/<stem>.npz (or ``path``, the
    depth stage's own intermediate files); a one-line error naming an unreadable file."""
    path = path or ws.depth_path(stem)
    try:
        with np.load(path) as z:
            return z["depth"].astype(np.float32), z["confidence"]
    except (OSError, ValueError, KeyError, EOFError) as e:
        raise UserError(f"{path} is unreadable ({type(e).__name__}): "
                        f"{ws.rerun('depth')}") from None


def write_depth(path: Path, depth: np.ndarray, confidence: np.ndarray,
                compressed: bool = True) -> Path:
    """Write a depth file: ``depth`` float32 (camera z in the normalised frame, 0 =
    unknown) and ``confidence`` float16 (0..1); WS/depth/<stem>.npz is ``compressed``."""
    save = np.savez_compressed if compressed else np.savez
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        save(fh, depth=np.asarray(depth, np.float32), confidence=confidence.astype(np.float16))
    return Path(path)


# --------------------------------------------------------------------------- flare.json
@dataclass
class FlareEntry:
    """One view of flare.json."""

    flare_fraction: float
    """Fraction of the view's pixels its mask marks as flare (rounded to 6 decimals)."""
    source: str
    """Where the mask came from: "fmg" (the network) or "masks" (hand-made)."""


@dataclass
class FlareFile:
    """``WS/flare.json``, written by the mask stage.

    ```
    {"source": "fmg" | "masks:<dir>", "threshold": cut | null, "weights": id | null,
     "views": {"<stem>": {"flare_fraction": f, "source": "fmg" | "masks"}}}
    ```
    """

    source: str
    """"fmg", or "masks:<absolute folder>" of hand-made masks."""
    threshold: float | None
    """The FMG probability cut used (--threshold, else the weights' calibrated one, else
    0.5); with hand-made masks, whatever the config held (null by default)."""
    weights: str | None
    """'<file name>@sha256:<first 16 hex>' of the FMG weights; null with hand-made masks."""
    views: dict[str, FlareEntry] = field(default_factory=dict)

    def fractions(self) -> dict[str, float]:
        """{stem: flare fraction}."""
        return {s: v.flare_fraction for s, v in self.views.items()}

    def to_json(self) -> dict:
        return {"source": self.source, "threshold": self.threshold, "weights": self.weights,
                "views": {s: {"flare_fraction": v.flare_fraction, "source": v.source}
                          for s, v in self.views.items()}}

    @classmethod
    def from_json(cls, d: dict) -> FlareFile:
        views = {s: FlareEntry(float(v["flare_fraction"]), str(v.get("source", "")))
                 for s, v in d.get("views", {}).items()}
        return cls(source=d.get("source", ""), threshold=d.get("threshold"),
                   weights=d.get("weights"), views=views)


def _read_stage_json(ws: Workspace, path: Path, stage: str, parse):
    """``parse`` of the JSON file ``stage`` writes; a one-line error naming the file and the
    command to run when it is missing or malformed."""
    if not path.exists():
        raise UserError(f"{path} is missing: run "
                        f"`deflare-scene {stage} {shell_path(ws.root)}` first")
    try:
        return parse(read_json(path))
    except (KeyError, TypeError, ValueError, AttributeError) as e:
        raise UserError(f"{path} is malformed ({e!r}): {ws.rerun(stage)}") from None


def read_flare(ws: Workspace) -> FlareFile:
    """WS/flare.json; a one-line error when it is missing or malformed."""
    return _read_stage_json(ws, ws.flare_json, "mask", FlareFile.from_json)


def write_flare(ws: Workspace, flare: FlareFile) -> Path:
    return atomic_write_json(ws.flare_json, flare.to_json())


# --------------------------------------------------------------------------- views.json
@dataclass
class SourceEntry:
    """One candidate source of a view in views.json."""

    stem: str
    distance: float
    """Distance between the two camera centres (normalised frame, rounded to 6 decimals)."""
    flare_fraction: float


@dataclass
class ViewEntry:
    """One view of views.json."""

    flare_fraction: float
    target: bool
    """May be a training target: flare fraction at most ``max_flare`` (``is_target``, the
    rule of ``gnfr.view_sampler``)."""
    sources: list[SourceEntry] = field(default_factory=list)
    """Every other view, nearest camera centre first."""


@dataclass
class ViewsFile:
    """``WS/views.json``, written by the select stage.

    ```
    {"max_flare": 0.1,
     "views": {"<stem>": {"flare_fraction": f, "target": bool,
                          "sources": [{"stem", "distance", "flare_fraction"}, ...]}}}
    ```
    """

    max_flare: float
    views: dict[str, ViewEntry] = field(default_factory=dict)

    # the one filtering rule ----------------------------------------------
    def __contains__(self, stem: object) -> bool:
        """Whether views.json lists the view ``stem``."""
        return stem in self.views

    def targets(self) -> list[str]:
        """Stems that may be training targets (their ``target`` flag)."""
        return [s for s, v in self.views.items() if v.target]

    def fractions(self, stems: Iterable[str] | None = None) -> dict[str, float]:
        """{stem: flare fraction} of ``stems`` (default: every view); a stem views.json
        does not list counts as flare-free (0.0)."""
        stems = self.views if stems is None else stems
        return {s: self.views[s].flare_fraction if s in self.views else 0.0 for s in stems}

    def sources(self, stem: str, among: Iterable[str] | None = None) -> list[str]:
        """The ranked source pool of ``stem``: the other views nearest first, the view
        itself never, and only views in ``among`` when given (those loaded or posed)."""
        keep = None if among is None else set(among)
        entry = self.views.get(stem)
        if entry is None:
            return []
        return [x.stem for x in entry.sources
                if x.stem != stem and (keep is None or x.stem in keep)]

    def ranked(self, stems: Sequence[str]) -> dict[str, list[str]] | None:
        """{stem: :meth:`sources` among ``stems``} for every stem, or None when views.json
        does not list every one of them (then the caller ranks by camera distance)."""
        if any(s not in self.views for s in stems):
            return None
        return {s: self.sources(s, among=stems) for s in stems}

    # JSON -------------------------------------------------------------------
    def to_json(self) -> dict:
        return {"max_flare": self.max_flare, "views": {
            s: {"flare_fraction": v.flare_fraction, "target": v.target,
                "sources": [{"stem": x.stem, "distance": x.distance,
                             "flare_fraction": x.flare_fraction} for x in v.sources]}
            for s, v in self.views.items()}}

    @classmethod
    def from_json(cls, d: dict) -> ViewsFile:
        views = {s: ViewEntry(float(v["flare_fraction"]), bool(v["target"]),
                              [SourceEntry(str(x["stem"]), float(x["distance"]),
                                           float(x["flare_fraction"]))
                               for x in v.get("sources", [])])
                 for s, v in d["views"].items()}
        return cls(max_flare=d["max_flare"], views=views)


def rank_sources(centers: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For camera centres [N, 3]: order [N, N-1] of the other views nearest first, and
    their distances [N, N-1]. Ties keep the input order (stable sort)."""
    d = np.linalg.norm(centers[:, None, :] - centers[None, :, :], axis=-1)   # [N, N]
    n = len(centers)
    order = np.empty((n, max(n - 1, 0)), int)
    for i in range(n):
        others = np.array([j for j in range(n) if j != i], int)
        order[i] = others[np.argsort(d[i, others], kind="stable")]
    return order, np.take_along_axis(d, order, axis=1)


def make_views(stems: list[str], centers: np.ndarray, fractions: dict[str, float],
               max_flare: float) -> ViewsFile:
    """The views.json of views ``stems`` with camera centres [N, 3] and flare fractions."""
    order, dist = rank_sources(np.asarray(centers, float))
    views = {}
    for i, s in enumerate(stems):
        views[s] = ViewEntry(
            flare_fraction=fractions[s], target=is_target(fractions[s], max_flare),
            sources=[SourceEntry(stems[j], round(float(dd), 6), fractions[stems[j]])
                     for j, dd in zip(order[i], dist[i], strict=True)])
    return ViewsFile(max_flare, views)


def read_views(ws: Workspace) -> ViewsFile:
    """WS/views.json; a one-line error when it is missing or malformed."""
    return _read_stage_json(ws, ws.views_json, "select", ViewsFile.from_json)


def write_views(ws: Workspace, views: ViewsFile) -> Path:
    return atomic_write_json(ws.views_json, views.to_json())
