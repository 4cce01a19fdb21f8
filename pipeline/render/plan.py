"""Frame planning: the jobs of a path, novel camera paths, their sizes and depth ranges."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from pipeline.cameras import Cameras, Frame
from pipeline.errors import UserError
from pipeline.progress import info
from pipeline.render.config import NAMED_PATHS, NOVEL_CPU_FILL, RenderConfig
from pipeline.render.jobs import FrameJob, SourceSet
from pipeline.render.sources import input_sources, novel_sources
from pipeline.workspace import Workspace, read_json
from pipeline.ws_files import ViewsFile


def plan_jobs(cfg: RenderConfig, ws: Workspace, cams: Cameras, views: ViewsFile,
              device: str) -> tuple[str, Path, list[FrameJob]]:
    """(path key, output folder, frame jobs) for ``cfg.path``."""
    if cfg.path == "inputs":
        if cfg.blend not in ("mask", "none"):
            raise UserError(f"--blend {cfg.blend!r} is not known: use mask or none")
        jobs = [FrameJob(ws.deflared_path(f.stem),
                         input_sources(f.stem, views, cfg, among=cams.stems), f.near, f.far, f)
                for f in cams.frames]
        return "inputs", ws.deflared, jobs
    points = scene_points(ws, cams) if cfg.path == "interpolate" else None
    path_cams, key = novel_path(cfg, cams, device, points)
    if key == "interpolate" and len(path_cams) > 1:
        info(pace_line(cfg, cams, path_cams, points))
        if line := zoom_line(cfg, cams):
            info(line)
    out_dir = ws.render_dir(cfg.path)
    spot_share = resolve_fill(cfg, device, novel=True).key_spot
    spot = spot_share * median_camera_distance(cams) if spot_share else 0.0
    jobs = []
    for i, pc in enumerate(path_cams):
        near, far = novel_depth_range(pc.c2w[:3, 3], cams)
        name = pc.name if key not in NAMED_PATHS else f"{i:05d}"
        jobs.append(FrameJob(out_dir / f"{name}.png", novel_sources(pc.c2w[:3, 3], cams, views,
                                                                    cfg), near, far, pc,
                             same_spot=spot))
    if cfg.source_hold:
        jobs = hold_sources(jobs, cams, views, cfg, cfg.source_hold)
    if cfg.source_fade:
        jobs = fade_or_not(fade_sources(jobs, cams, cfg.source_fade, cfg.photo_sources,
                                        cfg.fade_cut), cfg.fade_limit)
    return key, out_dir, jobs


def median_camera_distance(cams: Cameras) -> float:
    """The median distance between two of the input photos' cameras (0 with fewer than
    two): the scale of ``RenderConfig.key_spot``."""
    c = cams.centers()
    if len(c) < 2:
        return 0.0
    i, j = np.triu_indices(len(c), 1)
    return float(np.median(np.linalg.norm(c[i] - c[j], axis=1)))


def fade_or_not(jobs: list[FrameJob], limit: float) -> list[FrameJob]:
    """``jobs`` as faded (``fade_sources``), or with no fades where they would render more
    than ``limit`` images a frame over the path (``RenderConfig.fade_limit``; 0: always as
    faded), with one line saying so."""
    if limit <= 0 or not jobs:
        return jobs
    per_frame = float(np.mean([1 + len(j.fades) for j in jobs]))
    if per_frame <= limit:
        return jobs
    info(f"render: {sum(bool(j.fades) for j in jobs)} of {len(jobs)} frames stand beside a "
         f"change of sources (a densely photographed scene): rendered without the "
         f"cross-fade, which would take {per_frame:.2f} images a frame and soften them "
         f"(--set render.fade_limit=0 fades anyway)")
    return [replace(j, fades=()) for j in jobs]


FADE_STEP = 1.5
"""Consecutive frames of a path farther apart than this many times the photos' spacing (the
median distance from a photo's camera to its nearest other) are not cross-faded together
(``fade_sources``): a cut in a JSON path, or cameras that are not one shot (held-out views,
every second view or sparser: two spacings apart and more). A paced interpolate path of the
default length steps up to about one spacing where it crosses far scenery (0.4 to 1.0 on
the development builds of the fifty-second session)."""


def fill_first(job: FrameJob, cams: Cameras, k: int) -> tuple[str, ...]:
    """The ``k`` of a job's sources nearest its camera: the photos its fill takes first
    (``pipeline.render.fill.fill_from_photos`` sorts them the same way), or the job's own
    ``fill_first`` when it holds one."""
    if job.fill_first is not None:
        return tuple(job.fill_first)
    by = cams.by_stem()
    return tuple(job.fill_order(np.asarray(job.camera.c2w, float)[:3, 3],
                                lambda s: by[s].center, by)[:k])


def hold_sources(jobs: list[FrameJob], cams: Cameras, views: ViewsFile, cfg: RenderConfig,
                 margin: int) -> list[FrameJob]:
    """``jobs`` along a path with each frame holding the frame before's choice of sources
    (``RenderConfig.source_hold``): GN-FR's sources and the ``cfg.photo_sources`` photos the
    fill takes first are kept while (a) every source is among those the frame would choose
    with ``margin`` more (``novel_sources``), (b) the fill's first photos are among the
    ``photo_sources + margin`` of the sources nearest the frame, and (c) the input view
    nearest the frame is one of the sources and of the fill's first photos (the key blend
    leans to it). A frame that chooses anew holds its own choice from there."""
    if margin <= 0 or not jobs:
        return jobs
    k = cfg.photo_sources
    wider = replace(cfg, n_sources=int(cfg.n_sources or 10) + margin)
    by = cams.by_stem()
    held: tuple[list[str], tuple[str, ...]] | None = None
    out = []
    for job in jobs:
        c = np.asarray(job.camera.c2w, float)[:3, 3]
        if held is not None:
            sources, first = held
            allowed = set(novel_sources(c, cams, views, wider))
            nearest = min((s for s in by if s in views),
                          key=lambda s: float(np.linalg.norm(by[s].center - c)))
            near_k = fill_first(replace(job, sources=sources, fill_first=None), cams, k + margin)
            if (set(sources) <= allowed and set(first) <= set(near_k)
                    and nearest in first):
                out.append(replace(job, sources=list(sources), fill_first=tuple(first)))
                continue
        held = (job.sources, fill_first(job, cams, k))
        out.append(job)
    return out


def photo_spacing(cams: Cameras) -> float:
    """The median distance from a photo's camera to the nearest other one (0: fewer than
    two photos)."""
    c = cams.centers()
    if len(c) < 2:
        return 0.0
    d = np.linalg.norm(c[:, None] - c[None], axis=-1)
    np.fill_diagonal(d, np.inf)
    return float(np.median(d.min(axis=1)))


def exposure_along_path(jobs: list[FrameJob], cams: Cameras, gains: dict | None,
                        reach: float, k: int) -> list[FrameJob]:
    """``jobs`` (a novel path's) with each frame's ``exposure``
    (``RenderConfig.path_exposure``): the frames' own exposures, each the median gain of the
    ``k`` photos its fill takes first (the level its photo fill has without: ``stereo.
    match_gains`` brings them to their median), averaged over the path's frames by a
    Gaussian of the distance between their cameras, of ``reach`` photo spacings
    (``pipeline.exposure.path_gain``); the photos' gains beside it for the fill. As they are
    when ``reach`` is 0, the model has no gains, or the photos stand at one point."""
    from pipeline.exposure import path_gain

    sigma = reach * photo_spacing(cams)
    if reach <= 0 or not gains or sigma <= 0:
        return jobs
    photo = {s: np.asarray(g, np.float64) for s, g in gains.items()}
    centres = np.stack([np.asarray(j.camera.c2w, float)[:3, 3] for j in jobs])
    own = []
    for job in jobs:
        first = [s for s in fill_first(job, cams, k) if s in photo]
        own.append(np.median([photo[s] for s in first], axis=0) if first else None)
    kept = [i for i, g in enumerate(own) if g is not None]
    if not kept:
        return jobs
    out = []
    for job, c in zip(jobs, centres, strict=True):
        g = path_gain(c, centres[kept], [own[i] for i in kept], sigma)
        out.append(replace(job, exposure=tuple(round(float(x), 6) for x in g),
                           photo_gains=photo))
    return out


def fade_sources(jobs: list[FrameJob], cams: Cameras, radius: int, k: int,
                 cut: float = 0.0) -> list[FrameJob]:
    """``jobs`` with each frame's ``fades`` (``RenderConfig.source_fade``): a box of
    ``radius`` frames either side (shorter at the path's ends and at cuts: steps over
    ``FADE_STEP`` of the photos' spacing and, with ``cut`` (``RenderConfig.fade_cut``) over
    0, over ``cut`` times the path's median step too), in which each frame's choice (its
    sources and the ``k`` its fill takes first) counts once; the frame's own choice keeps its
    count's share, every other choice in the box is rendered at the frame's camera with the
    share of its count. A frame whose box holds only its own choice renders as before."""
    if radius <= 0 or len(jobs) < 2:
        return jobs
    firsts = [fill_first(j, cams, k) for j in jobs]
    keys = [(frozenset(j.sources), frozenset(f)) for j, f in zip(jobs, firsts, strict=True)]
    centres = np.stack([np.asarray(j.camera.c2w, float)[:3, 3] for j in jobs])
    steps = np.linalg.norm(np.diff(centres, axis=0), axis=1)
    limit = FADE_STEP * photo_spacing(cams)
    if cut > 0:
        limit = max(limit, cut * float(np.median(steps)))
    joined = steps < limit
    out = []
    for j, job in enumerate(jobs):
        lo = j
        while lo > 0 and j - lo < radius and joined[lo - 1]:
            lo -= 1
        hi = j
        while hi < len(jobs) - 1 and hi - j < radius and joined[hi]:
            hi += 1
        counts: dict = {}
        for i in range(lo, hi + 1):
            if keys[i] != keys[j]:
                counts.setdefault(keys[i], [i, 0])[1] += 1
        n = hi - lo + 1
        fades = tuple(SourceSet(tuple(jobs[i].sources), firsts[i], c / n)
                      for i, c in counts.values())
        out.append(replace(job, fades=fades) if fades else job)
    return out


# --------------------------------------------------------------------------- cameras
def novel_path(cfg: RenderConfig, cams: Cameras, device: str,
               points: np.ndarray | None = None):
    """(list of gnfr.paths.PathCamera, path key) for interpolate / spiral / FILE.json; the
    interpolate path paced by the image motion of ``points`` (:func:`scene_points`; None:
    ``gnfr.paths.bounds_points`` of the photos' bounds), or with ``cfg.pace`` ``travel`` at
    constant travel. The frames have the reference photo's size (:func:`reference_frame`,
    resized by :func:`resize_camera`) and its intrinsics, the interpolate path's zoomed to
    the photos' fields of view along the tour where ``cfg.zoom`` asks and the capture has
    more than one (:func:`resolve_zoom`)."""
    from gnfr import paths

    if cfg.path not in NAMED_PATHS:
        file = Path(cfg.path)
        if file.suffix.lower() != ".json":
            raise UserError(f"--path {cfg.path}: use inputs, interpolate, spiral or a .json "
                            "camera path file (docs/camera_paths.md)")
        if not file.is_file():
            raise UserError(f"--path {cfg.path}: no such camera path file; give an existing "
                            "one (docs/camera_paths.md) or interpolate / spiral")
        try:
            pcs = paths.path_from_json(read_json(
                file, fix="mend the file (format: docs/camera_paths.md)"))
        except ValueError as e:
            raise UserError(f"{file}: {e} (format: docs/camera_paths.md)") from None
        if cfg.size or cfg.scale:
            pcs = [resize_camera(pc, cfg, device) for pc in pcs]
        return pcs, file.stem
    if len(cams.frames) < 2:
        raise UserError(f"--path {cfg.path} needs at least 2 posed views; the workspace has "
                        f"{len(cams.frames)}")
    n = cfg.frames or max(1, round(cfg.seconds * cfg.fps))
    c2ws = np.stack([f.c2w for f in cams.frames])
    near = np.array([f.near for f in cams.frames])
    far = np.array([f.far for f in cams.frames])
    base = base_camera(cfg, cams, device)
    zoom = np.ones(n)
    if cfg.path == "interpolate":
        fov = path_fov(base)
        paced = pace_points(cams, points, fov) if cfg.pace == "image" else None
        tour = paths.interpolate_tour(c2ws, n, closed=paths.is_surrounding(c2ws),
                                      up=paths.world_up(c2ws), points=paced, fov=fov,
                                      tour=cfg.tour, depth=float(np.median(np.sqrt(near * far))),
                                      zoom=path_zoom(cfg, cams))
        poses, zoom = tour.poses, tour.zoom
    else:
        poses = paths.spiral_path(c2ws, near, far, n)
    return [paths.PathCamera(f"{i:05d}", zoomed(base.K, z), p, base.width, base.height)
            for i, (p, z) in enumerate(zip(poses, zoom, strict=True))], cfg.path


ZOOM_SPREAD = 1.05
"""The largest ratio between two photos' fields of view (:func:`photo_zoom`) at which an
interpolate path keeps one focal length (``RenderConfig.zoom``): photos of one camera at one
zoom, whose focal lengths the pose stage refines a little apart, do not make the video
breathe."""


def photo_zoom(cams: Cameras) -> np.ndarray:
    """[N] each photo's focal length over its long side, over the reference photo's
    (:func:`reference_frame`): the zoom that gives a frame of the reference's shape the
    photo's field of view along its long side."""
    ref = reference_frame(cams)
    return np.array([f.K[0][0] / max(f.width, f.height) for f in cams.frames]) / (
        ref.K[0][0] / max(ref.width, ref.height))


def path_zoom(cfg: RenderConfig, cams: Cameras) -> np.ndarray | None:
    """The photos' zooms (:func:`photo_zoom`) the path carries, or None where it keeps one
    focal length: every path but interpolate, ``zoom`` ``fixed``, and captures whose photos'
    fields of view lie within ZOOM_SPREAD."""
    if cfg.zoom != "photos" or cfg.path != "interpolate" or not len(cams.frames):
        return None
    z = photo_zoom(cams)
    return z if z.max() / z.min() > ZOOM_SPREAD else None


def resolve_zoom(cfg: RenderConfig, cams: Cameras) -> RenderConfig:
    """``cfg`` with ``zoom`` ``fixed`` where nothing zooms (:func:`path_zoom`), so the
    records, and frames, of a capture at one zoom stay those of before the option."""
    return cfg if path_zoom(cfg, cams) is not None else replace(cfg, zoom="fixed")


def zoom_line(cfg: RenderConfig, cams: Cameras) -> str | None:
    """One line saying the interpolate path zooms with the photos (their range of fields of
    view over the reference's) and how to keep one; None where it does not zoom."""
    z = path_zoom(cfg, cams)
    if z is None:
        return None
    return (f"render interpolate: the photos were taken at several zooms (focal lengths over "
            f"the long side {z.min():.2f} to {z.max():.2f} times the reference photo's); each "
            "frame takes the field of view of the photo it passes (--zoom fixed keeps one for "
            "every frame)")


def zoomed(K: np.ndarray, zoom: float) -> np.ndarray:
    """Intrinsics ``K`` with the focal lengths times ``zoom`` (the principal point kept);
    ``K`` itself at a zoom of 1."""
    if zoom == 1:
        return K
    K = np.asarray(K, np.float64).copy()
    K[0, 0] *= zoom
    K[1, 1] *= zoom
    return K


PACE_POINTS = 4000
"""Scene points the interpolate path's pace is measured on (``scene_points``): an even
sample of the depth maps' pixels, a few thousand being enough for a median shift."""


def scene_points(ws: Workspace, cams: Cameras) -> np.ndarray | None:
    """[P, 3] points of the scene for the interpolate path's pace: an even sample of
    PACE_POINTS of every 8th pixel of the photos' depth maps (WS/depth); None without
    depth maps (the path then paces on the photos' bounds)."""
    from pipeline.depth import depth_points

    if not ws.depth.is_dir():
        return None
    xyz = depth_points(ws, cams, stride=8, colour=False)[0]
    if len(xyz) > PACE_POINTS:
        xyz = xyz[np.random.default_rng(0).choice(len(xyz), PACE_POINTS, replace=False)]
    return xyz.astype(np.float64) if len(xyz) else None


def pace_points(cams: Cameras, points: np.ndarray | None, fov: tuple[float, float]
                ) -> np.ndarray:
    """The points the interpolate path is paced on: ``points`` (:func:`scene_points`), or
    without them ``gnfr.paths.bounds_points`` of the photos' bounds."""
    from gnfr import paths

    if points is not None and len(points):
        return points
    return paths.bounds_points(np.stack([f.c2w for f in cams.frames]),
                               [f.near for f in cams.frames], [f.far for f in cams.frames],
                               fov)


def path_fov(pc) -> tuple[float, float]:
    """(tan of the half-width, tan of the half-height angle) of a path camera's view."""
    return pc.width / 2 / pc.K[0][0], pc.height / 2 / pc.K[1][1]


CALM_PACE = 0.35
"""Share of the frame's width a second above which ``pace_line`` suggests a longer video
(a rule of thumb: a pan that crosses the frame in under three seconds judders at low frame
rates; the sample's tour at 4 s moves 0.68 of the width a second)."""


def pace_line(cfg: RenderConfig, cams: Cameras, path_cams: list,
              points: np.ndarray | None) -> str:
    """One line on how fast the interpolate path's frames move the scene (the median
    ``gnfr.paths.image_shift`` of ``points`` between frames, each in its own zoom, as a
    share of the width), with
    the ``--seconds`` that keeps it under CALM_PACE a second when it is over."""
    step = float(np.median(step_shares(cams, path_cams, points)))
    line = f"render interpolate: the scene moves about {step:.1%} of the frame's width a frame"
    if cfg.frames:  # the frame rate is the video's (export), not known here
        return line
    per_second = step * cfg.fps
    line += f", {per_second:.0%} a second at {cfg.fps:g} fps"
    if per_second > CALM_PACE:
        calm = int(np.ceil(cfg.seconds * per_second / CALM_PACE))
        line += f"; for a calmer video: --seconds {calm} (more frames to render)"
    return line


def step_shares(cams: Cameras, path_cams: list, points: np.ndarray | None) -> np.ndarray:
    """[F - 1] how far the scene moves between a path's frames, as a share of the frame's
    width: ``gnfr.paths.image_shift`` of ``points`` (:func:`pace_points`), each frame in its
    own zoom (its focal length over the first frame's)."""
    from gnfr import paths

    fov = path_fov(path_cams[0])
    poses = np.stack([p.c2w for p in path_cams])
    turn = paths.rotation_angle(poses[:-1, :3, :3], poses[1:, :3, :3])
    zoom = [p.K[0][0] / path_cams[0].K[0][0] for p in path_cams]
    shifts = paths.image_shift(poses, pace_points(cams, points, fov), fov, turn, zoom=zoom)
    return shifts / (2 * fov[0])


def base_camera(cfg: RenderConfig, cams: Cameras, device: str):
    """The built-in paths' camera before its pose and zoom: the reference photo's
    (:func:`reference_frame`) intrinsics and size, resized as ``cfg`` asks
    (:func:`resize_camera`)."""
    from gnfr.paths import PathCamera

    ref = reference_frame(cams)
    return resize_camera(PathCamera("ref", ref.K, ref.c2w, ref.width, ref.height), cfg, device)


def reference_frame(cams: Cameras) -> Frame:
    """The first view with the most common image size (its K sets novel intrinsics)."""
    sizes = [(f.width, f.height) for f in cams.frames]
    common = max(set(sizes), key=sizes.count)
    return cams.frames[sizes.index(common)]


def resize_camera(pc, cfg: RenderConfig, device: str):
    """A PathCamera scaled to ``cfg.size`` or by ``cfg.scale`` (default by device)."""
    from gnfr.paths import PathCamera

    if cfg.size:
        W, H = (int(v) for v in cfg.size)
    else:
        s = novel_scale(cfg, device)
        W, H = max(1, round(pc.width * s)), max(1, round(pc.height * s))
    K = np.asarray(pc.K, np.float64).copy()
    K[0] *= W / pc.width
    K[1] *= H / pc.height
    return PathCamera(pc.name, K, pc.c2w, W, H)


def novel_scale(cfg: RenderConfig, device: str) -> float:
    """Novel frames' size as a fraction of the input views': 1 on CUDA and with the hybrid
    fill (the photos give the detail), 1/4 for the network alone on CPU."""
    if cfg.scale:
        return float(cfg.scale)
    return 1.0 if device.startswith("cuda") or cfg.fill == "hybrid" else 0.25


def resolve_fill(cfg: RenderConfig, device: str, novel: bool) -> RenderConfig:
    """``cfg`` with the hybrid fill's ``network_scale``, ``agree_window``, ``network_depth``,
    ``key_blend``, ``novel_agree`` and ``key_spot`` resolved where not given:
    ``NOVEL_CPU_FILL``'s for hybrid novel frames on the CPU; a 1-pixel agreement, the depth
    maps' depth, no key blend and the photo fill's own tolerance for the de-flared photos,
    on CUDA and where GN-FR renders every pixel (``fill`` network: none is used).
    GN-FR's share of a novel frame is 1 on CUDA and ``NOVEL_CPU_FILL``'s on the CPU (with
    ``fill`` network too, where nothing reads it: the value its records hold); the de-flared
    photos' GN-FR renders at their own size, so theirs stays unset. The one place those
    defaults are resolved (the render records them; a benchmark that calls the fill itself
    resolves them here too)."""
    from pipeline.photo_fill import AGREE

    cpu = not device.startswith("cuda")
    cpu_novel = novel and cpu and cfg.fill == "hybrid"
    scale = cfg.network_scale
    if scale is None and novel:
        scale = float(NOVEL_CPU_FILL["network_scale"]) if cpu else 1.0
    return replace(cfg, network_scale=scale,
                   agree_window=cfg.agree_window or (
                       NOVEL_CPU_FILL["agree_window"] if cpu_novel else 1),
                   network_depth=cfg.network_depth or (
                       NOVEL_CPU_FILL["network_depth"] if cpu_novel else "off"),
                   key_blend=cfg.key_blend if cfg.key_blend is not None else (
                       NOVEL_CPU_FILL["key_blend"] if cpu_novel else 0.0),
                   novel_agree=cfg.novel_agree if novel and cfg.novel_agree is not None
                   else NOVEL_CPU_FILL["novel_agree"] if cpu_novel else AGREE,
                   key_spot=cfg.key_spot if cfg.key_spot is not None else (
                       NOVEL_CPU_FILL["key_spot"] if cpu_novel else 0.0))


def depth_samples(cfg: RenderConfig, device: str, samples: int, novel: bool) -> int:
    """Samples in the band around a ray's confirmed depth (hybrid fill; 0 = the whole ray):
    ``cfg.depth_samples`` when set; otherwise none for novel frames on the CPU (GN-FR's
    pixels sampled along the whole ray gave the development scenes' held-out views +0.22 dB
    and +0.045 SSIM: docs/history/fill.md, "GN-FR's pixels of novel frames sampled along the
    whole ray"), a third of ``samples`` (at least 4) elsewhere."""
    if cfg.fill != "hybrid":
        return 0
    if cfg.depth_samples is not None:
        return int(cfg.depth_samples)
    if novel and not device.startswith("cuda"):
        return 0
    return max(4, samples // 3)


def novel_depth_range(center: np.ndarray, cams: Cameras, k: int = 3) -> tuple[float, float]:
    """(near, far) of a novel camera: the range spanned by its ``k`` nearest input views."""
    d = np.linalg.norm(cams.centers() - center, axis=1)
    idx = np.argsort(d, kind="stable")[:k]
    return (float(min(cams.frames[i].near for i in idx)),
            float(max(cams.frames[i].far for i in idx)))
