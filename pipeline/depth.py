"""Stage `depth`: per-view depth and confidence from the posed photos (plane-sweep stereo).

Writes ``WS/depth/<stem>.npz`` with ``depth`` [H, W] float32 (camera z-depth in the
normalised world frame of WS/cameras.json, at the size of WS/images/<stem>.png; 0 = unknown)
and ``confidence`` [H, W] float16 (0..1). The algorithm (docs/depth.md): for each view, a
plane sweep over its nearest ``neighbours`` views with windowed ZNCC, best-k source costs
(a flared or occluding neighbour cannot spoil a pixel: flare-masked source pixels are never
matched), sub-plane refinement, then a multi-view consistency check that keeps a depth only
where another view's depth agrees. Render uses the depths to warp clean photo pixels into
flare regions and novel frames (pipeline/photo_fill.py).

With ``frames_sgm`` (the default) the stage also writes ``WS/depth/frames/<stem>.npz`` in the
same format: the same sweep with its costs aggregated along four scanlines
(``pipeline.stereo.aggregate_sgm``), which only the novel frames warp the photos through
(docs/depth.md, "Maps for the novel frames").
"""

from __future__ import annotations

import hashlib
import shutil
import warnings
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from pipeline.cameras import Cameras
from pipeline.errors import UserError
from pipeline.options import option, validate
from pipeline.progress import info, track
from pipeline.stereo import (
    PosedView,
    SweepConfig,
    backproject,
    consistency_count,
    sweep_depths,
)
from pipeline.workspace import Workspace
from pipeline.ws_files import read_cameras, read_depth, read_mask, read_view_image, write_depth

__all__ = ["DepthConfig", "depth_points", "load_views", "nearest_views", "read_depth", "run",
           "sweep_key", "sweep_views"]
# read_depth: pipeline/ws_files.py (the WS/depth reader), named here for its callers


@dataclass
class DepthConfig:
    """Options of the depth stage."""

    neighbours: int = option(4, ge=1)
    """Nearest views (camera centres) each view is matched against."""
    planes: int = option(48, ge=3)
    """Depth hypotheses per view, uniform in inverse depth between its near and far."""
    window: int = option(7, ge=3, odd=True)
    """Matching window side (pixels, odd)."""
    keep: int = option(2, ge=1, le="neighbours")
    """Best-k: a pixel's cost is the mean of its k best neighbours' costs."""
    min_confidence: float = option(0.5, ge=0, le=1)
    """Depths below this confidence (1 - ZNCC cost) are dropped."""
    consistency: float = option(0.02, ge=0, lt=1)
    """Keep a depth only where a neighbour's depth agrees within this relative difference
    (0: no check)."""
    min_margin: float = option(0.0, ge=0, le=2)
    """Drop a depth whose matching cost beats the best cost of the planes away from it by
    less than this (uniqueness; 0: no test; docs/history/fill.md, "A match must be unique")."""
    consistency_planes: float = option(0.0, ge=0)
    """The consistency check's tolerance in planes of the view's own sweep, in inverse depth
    (0: the relative ``consistency`` instead; docs/history/fill.md, "Consistency in planes")."""
    sgm: tuple[float, float] | None = option(None, gt=0)
    """P1,P2: semi-global aggregation of each view's matching costs along four scanlines
    (a depth one plane away from a scanline neighbour's costs P1, a larger jump P2, halved at
    an image edge), so weakly textured pixels take their neighbours' depth (none: each
    pixel's own cost; docs/depth.md)."""
    frames_sgm: tuple[float, float] | None = option((0.1, 1.0), gt=0)
    """P1,P2 of a second set of maps, ``WS/depth/frames/``, that only the novel frames warp
    the photos through: the sweep's costs aggregated as ``sgm`` aggregates them, so weakly
    textured pixels of the video take their neighbours' depth; the de-flared photos, the
    fine-tune's exposure gains and the export read ``WS/depth`` (the mask stage's own
    sweeps are never aggregated); none: the novel frames use ``WS/depth`` too
    (docs/depth.md, "Maps for the novel frames")."""

    def sweep(self) -> SweepConfig:
        return SweepConfig(planes=self.planes, window=self.window, keep=self.keep,
                           min_confidence=self.min_confidence, consistency=self.consistency,
                           min_margin=self.min_margin, sgm=self.sgm)

    def rules(self) -> None:
        """The rules between numbers (``pipeline.options.validate`` calls it after each
        field's range): the aggregation's penalties P1 <= P2."""
        for flag, pen in (("--sgm", self.sgm), ("--frames-sgm", self.frames_sgm)):
            if pen is not None and not 0 < pen[0] <= pen[1]:
                raise UserError(f"{flag} {pen[0]:g},{pen[1]:g}: the penalties must be P1,P2 "
                                f"with 0 < P1 <= P2 (e.g. {flag} 0.1,1), or none")

    def frames(self) -> DepthConfig | None:
        """The settings of the novel frames' maps (``frames_sgm``), or None when they are
        the main maps (no ``frames_sgm``, or the same aggregation as ``sgm``)."""
        if self.frames_sgm is None or tuple(self.frames_sgm) == tuple(self.sgm or ()):
            return None
        return replace(self, sgm=tuple(self.frames_sgm))


def nearest_views(cams: Cameras, n: int) -> dict[str, list[str]]:
    """Per stem, the ``n`` other views with the nearest camera centres."""
    c = cams.centers()
    d = np.linalg.norm(c[:, None] - c[None], axis=-1)
    stems = cams.stems
    return {s: [stems[j] for j in np.argsort(d[i], kind="stable") if j != i][:n]
            for i, s in enumerate(stems)}


def load_views(ws: Workspace, cams: Cameras, stems: list[str],
               with_depth: bool = False, masks: dict[str, np.ndarray] | None = None,
               frames: bool = False) -> dict[str, PosedView]:
    """{stem: PosedView} of WS/images (float RGB), flare masks as validity (``masks`` when
    given, else WS/masks where it has them), and WS/depth where ``with_depth`` and present
    (with ``frames``, the novel frames' maps WS/depth/frames)."""
    by = cams.by_stem()
    out = {}
    for s in stems:
        if masks is not None:
            valid = ~masks[s]
        else:
            valid = ~read_mask(ws, s) if ws.mask_path(s).exists() else None
        path = ws.depth_path(s, frames)
        depth = read_depth(ws, s, path)[0] if with_depth and path.exists() else None
        out[s] = PosedView(read_view_image(ws, s, as_float=True), np.array(by[s].K, float),
                           np.array(by[s].c2w), valid, depth)
    return out


def _view_digest(v: PosedView) -> bytes:
    """SHA-256 of what a plane sweep reads of one view: pixels, flare mask, camera."""
    h = hashlib.sha256()
    for a in (v.image, v.valid, v.K, v.c2w):
        h.update(b"-" if a is None else np.ascontiguousarray(a).tobytes())
    return h.digest()


def sweep_key(views: dict[str, PosedView], s: str, near: list[str], bounds: tuple[float, float],
              sweep: SweepConfig, digests: dict[str, bytes] | None = None) -> str:
    """Hex key of one view's plane sweep: its own and its ``near`` views' pixels, flare masks
    and cameras, its depth ``bounds`` and the ``sweep`` settings. Equal keys give equal
    sweeps (the sweep is deterministic). ``digests``: per-view digests already computed."""
    digests = digests if digests is not None else {}
    h = hashlib.sha256(repr((list(bounds), asdict(sweep), near)).encode())
    for t in [s, *near]:
        if t not in digests:
            digests[t] = _view_digest(views[t])
        h.update(digests[t])
    return h.hexdigest()


def sweep_views(views: dict[str, PosedView], cams: Cameras, near: dict[str, list[str]],
                config: DepthConfig, raw_dir: Path, keep_raw: bool, ws: Workspace,
                label: str = "depth: plane sweep", shared: Path | None = None,
                taken: list[str] | None = None,
                also: tuple[tuple[float, float], Path] | None = None
                ) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """{stem: (depth, confidence)} of every view of ``views`` (their flare masks as
    validity): the plane sweep against its ``near`` views, each result kept in
    ``raw_dir/<stem>.npz`` (taken from there when ``keep_raw``: a resumed run), then the
    multi-view consistency check. Sets each view's ``depth`` to its swept depth.
    ``shared``: a folder of sweeps another stage made (``<stem>.npz`` beside ``<stem>.key``,
    :func:`sweep_key`); a view whose key matches is moved from there, not swept again, and
    every view swept here is added to it when ``shared`` is ``raw_dir``; the stems taken
    from another folder are appended to ``taken``. ``also`` = (P1,P2, folder): each view
    swept here also leaves the same cost volume's aggregated winner in ``folder/<stem>.npz``
    (``pipeline.stereo.sweep_depths``), which a second call with those penalties and
    ``keep_raw`` takes instead of sweeping again."""
    by = cams.by_stem()
    sweep = config.sweep()
    digests: dict[str, bytes] = {}
    got: list[str] = []
    for s in track(cams.stems, label):
        raw = raw_dir / f"{s}.npz"
        if keep_raw and raw.exists():
            continue
        key = None
        if shared is not None:
            key = sweep_key(views, s, near[s], (by[s].near, by[s].far), sweep, digests)
            have, kf = shared / f"{s}.npz", shared / f"{s}.key"
            if have.exists() and kf.exists() and kf.read_text() == key:
                if have != raw:
                    have.replace(raw)  # moved, not copied: the folder is removed after
                    got.append(s)
                continue
            if shared == raw_dir:
                kf.unlink(missing_ok=True)  # never an old key beside a new sweep
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            got_depths = sweep_depths(views[s], [views[n] for n in near[s]], by[s].near,
                                      by[s].far, sweep, None if also is None else also[0])
        write_depth(raw, *got_depths[0], compressed=False)
        if also is not None:
            write_depth(also[1] / f"{s}.npz", *got_depths[1], compressed=False)
        if key is not None and shared == raw_dir:
            (shared / f"{s}.key").write_text(key)
    if got:
        info(f"{label.split(':')[0]}: {len(got)} of {len(cams.stems)} views' plane sweeps "
             f"taken from the mask stage's ({shared})")
    if taken is not None:
        taken.extend(got)
    confs = {}
    for s in cams.stems:
        views[s].depth, confs[s] = read_depth(ws, s, raw_dir / f"{s}.npz")
    return consistent_depths(views, confs, cams, near, config)


def consistent_depths(views: dict[str, PosedView], confs: dict[str, np.ndarray],
                      cams: Cameras, near: dict[str, list[str]], config: DepthConfig
                      ) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """{stem: (depth, confidence)}: each view's swept ``depth`` (and ``confs``) zeroed where
    no ``near`` view agrees with it (the multi-view consistency check; kept as swept when
    ``config`` turns the check off)."""
    by = cams.by_stem()
    order = list(cams.stems)
    idx = {t: i for i, t in enumerate(order)}
    ordered = [views[t] for t in order]
    out = {}
    for s in order:
        d, conf = views[s].depth, confs[s]
        if config.consistency > 0 or config.consistency_planes > 0:
            step = (1.0 / by[s].near - 1.0 / by[s].far) / max(config.planes - 1, 1)
            cnt = consistency_count(ordered, idx[s], [idx[n] for n in near[s]],
                                    config.consistency,
                                    inverse_tol=config.consistency_planes * step or None)
            d = np.where(cnt >= 1, d, 0).astype(np.float32)
            conf = np.where(cnt >= 1, conf, 0).astype(np.float16)
        out[s] = (d, conf)
    return out


def run(config: DepthConfig, ws: Workspace, force: bool = False) -> list[Path]:
    """Write WS/depth/<stem>.npz for every view; returns [WS/depth]."""
    validate(config)
    ws.require("pose")
    cams = read_cameras(ws)
    masks = [ws.mask_path(s) for s in cams.stems if ws.mask_path(s).exists()]
    stage_run = ws.begin_stage("depth", asdict(config), [ws.cameras_json, ws.images, *masks],
                               force, defaults=asdict(DepthConfig()))
    out_dir = ws.depth
    if stage_run.skip:
        shutil.rmtree(ws.sweeps, ignore_errors=True)
        info(f"depth: up to date ({out_dir})")
        return stage_run.outputs
    if len(cams.stems) < 2:
        raise UserError(f"{ws.cameras_json}: depth needs at least 2 posed views")
    raw_dir = out_dir / ".raw"
    raw_dir.mkdir(parents=True, exist_ok=True)
    frames_raw = out_dir / ".raw_frames"
    frames_cfg = config.frames()
    if not ws.resumable(stage_run):  # a winner of other settings is never taken below
        shutil.rmtree(frames_raw, ignore_errors=True)
    if frames_cfg is not None:
        frames_raw.mkdir(exist_ok=True)
    near = nearest_views(cams, config.neighbours)
    views = load_views(ws, cams, cams.stems)
    taken: list[str] = []
    # each view swept here leaves both winners of its one cost volume; the views whose
    # sweep comes from the mask stage are swept once more for the aggregated one
    depths = sweep_views(views, cams, near, config, raw_dir, ws.resumable(stage_run), ws,
                         shared=ws.sweeps if ws.sweeps.is_dir() else None, taken=taken,
                         also=None if frames_cfg is None else (frames_cfg.sgm, frames_raw))
    frames = None
    if frames_cfg is not None:
        frames = sweep_views(views, cams, near, frames_cfg, frames_raw, True, ws,
                             label="depth: aggregated sweep for the novel frames")
    kept, kept_frames = [], []
    for s, (d, conf) in depths.items():
        write_depth(ws.depth_path(s), d, conf)
        kept.append(float((d > 0).mean()))
    shutil.rmtree(ws.depth_frames, ignore_errors=True)  # none left of other settings
    for s, (d, conf) in (frames or {}).items():
        write_depth(ws.depth_path(s, frames=True), d, conf)
        kept_frames.append(float((d > 0).mean()))
    for raw in (raw_dir, frames_raw):
        shutil.rmtree(raw, ignore_errors=True)
    shutil.rmtree(ws.sweeps, ignore_errors=True)  # the mask stage's, used or out of date
    extra = {"coverage": round(float(np.mean(kept)), 4), "sweeps_from_mask_stage": len(taken)}
    if frames:
        extra["coverage_frames"] = round(float(np.mean(kept_frames)), 4)
    stage_run.finish([out_dir], extra=extra)
    info(f"depth: {len(depths)} views -> {out_dir} (depth known on {100 * np.mean(kept):.0f}% "
         "of pixels on average" + (f"; {100 * np.mean(kept_frames):.0f}% in the novel frames' "
                                   "maps, WS/depth/frames" if frames else "") + ")")
    if (note := few_depth_note(float(np.mean(kept_frames or kept)), config)) is not None:
        info(note)
    return [out_dir]


FEW_DEPTH = 0.2
"""Mean share of the pixels with a depth under which the depth stage points at the options
measured for such captures (the development street walk: 10 %; the others 32-50 %)."""


def few_depth_note(coverage: float, config: DepthConfig) -> str | None:
    """A note when the maps the video warps through (the novel frames' own where written)
    know little (a street walk, a deep scene): the video's photo share will be small; the
    opt-ins measured on such a capture. None otherwise (or when the depth stage's looser
    check is already on). ``coverage``: the mean share of pixels with a depth in those
    maps."""
    if coverage >= FEW_DEPTH or config.consistency_planes:
        return None
    aggregated = config.sgm is not None or config.frames_sgm is not None
    return (f"depth: known on few pixels ({100 * coverage:.0f}%): the video will take little "
            "from the photos. For a street walk or another deep scene, "
            "`--set depth.consistency_planes=1` (more depth kept), "
            + ("" if aggregated else "`--set depth.frames_sgm=0.1,1` (weakly textured pixels "
               "take their neighbours' depth), ")
            + "or, on a GPU, `--set render.network_depth=holes` (the photos warped through "
            "GN-FR's own depth; the CPU's default) each sharpened the development street "
            "walk's frames a little (docs/options.md)")


def depth_points(ws: Workspace, cams: Cameras, stride: int = 1, colour: bool = True
                 ) -> tuple[np.ndarray, np.ndarray | None]:
    """(xyz [N, 3] float32 in the world frame of cameras.json, rgb [N, 3] uint8) of every
    known pixel (every ``stride``-th in each direction) of every view's depth map, coloured
    by WS/images (rgb None without ``colour``: the photos are not read)."""
    import cv2

    xyz, rgb = [], []
    for f in cams.frames:
        if not ws.depth_path(f.stem).exists():
            continue
        depth = read_depth(ws, f.stem)[0]
        K = np.array(f.K, float)
        if depth.shape != (f.height, f.width):  # a depth map at another size than the photo
            K[0] *= depth.shape[1] / f.width
            K[1] *= depth.shape[0] / f.height
        pts = backproject(K, np.array(f.c2w, float), depth)[::stride, ::stride]
        known = depth[::stride, ::stride] > 0
        xyz.append(pts[known].astype(np.float32))
        if colour:
            image = read_view_image(ws, f.stem)
            if image.shape[:2] != depth.shape:
                image = cv2.resize(image, depth.shape[::-1], interpolation=cv2.INTER_AREA)
            rgb.append(image[::stride, ::stride][known])
    if not xyz:
        return np.zeros((0, 3), np.float32), np.zeros((0, 3), np.uint8) if colour else None
    return np.concatenate(xyz), np.concatenate(rgb) if colour else None
