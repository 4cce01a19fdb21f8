"""Pose stage: structure from motion with pycolmap, in process (no shell calls).

Reads ``WS/decoded``; writes ``WS/colmap/database.db``, ``WS/colmap/sparse/0`` (the largest
model, binary, readable by COLMAP), ``WS/colmap/report.json`` (registration report),
``WS/images/<stem>.png`` (undistorted to PINHOLE), ``WS/cameras.json`` and ``WS/scene.glb``.

Steps: (1) one COLMAP camera per group of photos with the same decoded size and EXIF focal
length (the focal length, read from the original photo's EXIF when it has one, is a prior);
(2) SIFT extraction (GPU when pycolmap has CUDA); (3) exhaustive matching for small sets,
sequential matching for large or video-like ones (``matcher="auto"``); (4) incremental
mapping, keeping the model with the most registered images; when fewer than half of the
images register, mapping again with the initial-pair constraints relaxed for forward motion
(``RELAXED_INIT``), and when images are still left out, once more with the triangulation
angle and registration inlier thresholds lowered too (``LOOSE``; ``loose_pass``); every pass
run is in report.json ``mapping``; (5) undistortion to PINHOLE
(COLMAP's undistorted camera, OpenCV remap: the same pixels as COLMAP's undistorter);
(6) the normalised world frame: translate the median of the sparse points to the origin
and scale so the farthest camera is at distance 1 (no rotation), recorded as
``colmap_to_world``; (7) per view near/far from the depths of the sparse points it sees
(1st/99th percentiles, widened by ``depth_margin``).

``colmap_model`` imports an existing reconstruction instead of solving (images matched by
stem); then no database is written. Resume: the database keeps extracted features and
matches of an interrupted run, so a rerun continues from there.
"""

from __future__ import annotations

import re
import shutil
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from pipeline import colmap_io
from pipeline.camera_models import MODELS
from pipeline.cameras import Cameras, Frame, normalising_scale
from pipeline.errors import UserError, shell_path
from pipeline.images import read_image
from pipeline.options import option, validate
from pipeline.progress import console, info, make_progress, warn
from pipeline.scene_glb import write_scene_glb
from pipeline.workspace import Workspace, atomic_imwrite, atomic_write_json
from pipeline.ws_files import write_cameras

MATCHERS = ("auto", "exhaustive", "sequential")


@dataclass
class PoseConfig:
    matcher: str = option("auto", choices=MATCHERS)
    """exhaustive, sequential, or auto (exhaustive up to ``exhaustive_max`` images unless the
    names look like video frames)."""
    colmap_model: str | None = None
    """Import this COLMAP sparse model (folder) instead of solving; images matched by stem."""
    camera_model: str = option("SIMPLE_RADIAL", choices=tuple(MODELS))
    """COLMAP camera model to estimate (e.g. OPENCV for strong or wide-angle distortion)."""
    max_num_features: int = option(8192, ge=1)
    """SIFT features per image."""
    exhaustive_max: int = option(60, ge=0)
    """auto: the largest image count matched exhaustively."""
    sequential_overlap: int = option(10, ge=1)
    """Sequential matching: neighbours matched on each side (plus quadratic overlap)."""
    loose_pass: bool = True
    """Map once more with LOOSE when images are still left out (a walk forward, small
    baselines); the pass that registers more images is kept."""
    min_registered_fraction: float = option(0.5, gt=0, le=1)
    """Fail when fewer than this fraction of the images (or fewer than 3) register."""
    depth_margin: float = option(1.3, ge=1)
    """near = 1st depth percentile / margin, far = 99th percentile * margin."""
    num_threads: int = option(-1, ge=-1, flag="--threads")
    """CPU threads for COLMAP (-1: all)."""
    seed: int = option(0, ge=0)
    """Random seed of COLMAP's RANSAC and mapper (one thread makes runs repeatable)."""
    colmap_log: bool = False
    """Show COLMAP's own log (glog) on stderr."""


# --------------------------------------------------------------------------- matching
def looks_like_video(names: list[str], min_frames: int = 30) -> bool:
    """True for many files named ``<prefix><number>`` with consecutive numbers."""
    if len(names) < min_frames:
        return False
    parsed = [re.fullmatch(r"(.*?)(\d+)", Path(n).stem) for n in names]
    if not all(parsed) or len({m.group(1) for m in parsed}) != 1:
        return False
    nums = sorted(int(m.group(2)) for m in parsed)
    return nums[-1] - nums[0] == len(nums) - 1


def choose_matcher(cfg: PoseConfig, names: list[str]) -> str:
    if cfg.matcher not in MATCHERS:
        raise UserError(f"--matcher {cfg.matcher!r} is not one of {', '.join(MATCHERS)}")
    if cfg.matcher != "auto":
        return cfg.matcher
    big = len(names) > cfg.exhaustive_max
    return "sequential" if big or looks_like_video(names) else "exhaustive"


# --------------------------------------------------------------------------- geometry
def normalising_transform(centers: np.ndarray, points: np.ndarray) -> np.ndarray:
    """[4, 4] similarity taking COLMAP coordinates to the normalised world frame.

    centers [N, 3] camera centres, points [M, 3] sparse points (COLMAP frame). The median
    point (or the mean camera centre when there are no points) goes to the origin; the
    farthest camera ends at distance 1.
    """
    origin = np.median(points, 0) if len(points) else centers.mean(0)
    s = normalising_scale(centers, origin)
    T = np.eye(4)
    T[:3, :3] *= s
    T[:3, 3] = -s * origin
    return T


def transform_c2w(T: np.ndarray, c2w: np.ndarray) -> np.ndarray:
    """Apply a similarity T [4, 4] (uniform scale) to a camera-to-world c2w [4, 4]."""
    s = np.cbrt(np.linalg.det(T[:3, :3]))
    out = np.eye(4)
    out[:3, :3] = T[:3, :3] @ c2w[:3, :3] / s
    out[:3, 3] = T[:3, :3] @ c2w[:3, 3] + T[:3, 3]
    return out


def near_far(depths: np.ndarray, margin: float, fallback: tuple[float, float]
             ) -> tuple[float, float]:
    """Robust (near, far) from point depths [M] along the view axis."""
    d = depths[depths > 0]
    if len(d) < 8:
        return fallback
    lo, hi = np.percentile(d, [1, 99])
    return float(max(lo / margin, 1e-3 * hi)), float(hi * margin)


# --------------------------------------------------------------------------- inputs
def png_size(path: Path) -> tuple[int, int]:
    """(width, height) of a PNG from its header."""
    with open(path, "rb") as f:
        head = f.read(24)
    if head[:8] != b"\x89PNG\r\n\x1a\n":
        raise UserError(f"{path} is not a PNG: rerun `deflare-scene decode` with --force")
    return int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")


def focal_prior(photo: Path | None, size: tuple[int, int]) -> float | None:
    """EXIF focal length of the original photo in pixels of the decoded size, if known."""
    from pipeline.video_input import is_video

    pycolmap = colmap_io.import_pycolmap()
    if photo is None or not photo.is_file() or is_video(photo):  # a video's frame: no EXIF
        return None
    try:
        cam = pycolmap.infer_camera_from_image(str(photo))
    except ValueError:  # not readable by COLMAP (e.g. camera raw): no prior
        return None
    if not cam.has_prior_focal_length:
        return None
    return float(cam.mean_focal_length()) * max(size) / max(cam.width, cam.height)


@dataclass
class Inputs:
    """What the pose stage reads: decoded stems, their original names and sizes."""

    stems: list[str]
    sources: dict[str, str]
    sizes: dict[str, tuple[int, int]]
    photos: Path | None

    @classmethod
    def of(cls, ws: Workspace) -> Inputs:
        sources = ws.stage_record("decode").get("sources") or {
            p.stem: p.name for p in ws.decoded.glob("*.png")}  # workspaces made by hand
        stems = sorted(s for s in sources if ws.decoded_path(s).is_file())
        if not stems:
            raise UserError(f"{ws.decoded} has no decoded images: rerun `deflare-scene decode "
                            "PHOTOS --out " + shell_path(ws.root) + " --force`")
        sizes = {s: png_size(ws.decoded_path(s)) for s in stems}
        return cls(stems, sources, sizes, ws.photos_dir)


# --------------------------------------------------------------------------- solve
def _import_images(cfg: PoseConfig, db: Path, decoded: Path, inp: Inputs) -> None:
    """Add the images not yet in the database, one camera per (size, EXIF focal) group."""
    pycolmap = colmap_io.import_pycolmap()
    database = pycolmap.Database.open(str(db))
    existing = {im.name for im in database.read_all_images()}
    database.close()
    groups: dict[tuple, list[str]] = {}
    for stem in inp.stems:
        if f"{stem}.png" in existing:
            continue
        size = inp.sizes[stem]
        photo = inp.photos / inp.sources[stem] if inp.photos else None
        f = focal_prior(photo, size)
        groups.setdefault((size, None if f is None else round(f, 1)), []).append(f"{stem}.png")
    for (size, f), names in groups.items():
        opts = pycolmap.ImageReaderOptions()
        opts.camera_model = cfg.camera_model
        if f is not None:
            cam = pycolmap.Camera.create_from_model_name(1, cfg.camera_model, f, *size)
            opts.camera_params = cam.params_to_string()
        pycolmap.import_images(str(db), str(decoded), pycolmap.CameraMode.SINGLE, names, opts)


def _extract(cfg: PoseConfig, db: Path, decoded: Path, names: list[str]) -> None:
    pycolmap = colmap_io.import_pycolmap()
    opts = pycolmap.FeatureExtractionOptions()
    opts.num_threads = cfg.num_threads
    opts.use_gpu = bool(pycolmap.has_cuda)
    opts.sift.max_num_features = cfg.max_num_features
    reader = pycolmap.ImageReaderOptions()
    reader.camera_model = cfg.camera_model
    chunk = max(4, -(-len(names) // 10))  # about ten progress steps
    with make_progress() as prog:
        task = prog.add_task("pose: SIFT features", total=len(names))
        for i in range(0, len(names), chunk):
            pycolmap.extract_features(str(db), str(decoded), names[i:i + chunk],
                                      pycolmap.CameraMode.AUTO, reader, opts)
            prog.advance(task, len(names[i:i + chunk]))


def _match(cfg: PoseConfig, db: Path, matcher: str) -> None:
    pycolmap = colmap_io.import_pycolmap()
    opts = pycolmap.FeatureMatchingOptions()
    opts.num_threads = cfg.num_threads
    opts.use_gpu = bool(pycolmap.has_cuda)
    verify = pycolmap.TwoViewGeometryOptions()
    verify.ransac.random_seed = cfg.seed
    info(f"pose: {matcher} matching")
    if matcher == "exhaustive":
        pycolmap.match_exhaustive(str(db), opts, verification_options=verify)
    else:
        pairing = pycolmap.SequentialPairingOptions()
        pairing.overlap = cfg.sequential_overlap
        pycolmap.match_sequential(str(db), opts, pairing, verify)


# Initial-pair constraints of the retry. COLMAP's defaults (|t_z| < 0.95, median triangulation
# angle > 16 degrees, which it relaxes to 4 degrees at most) reject every neighbouring pair of a
# walk forward: lund's have |t_z| ~ 0.999 and 1-3 degrees (with 100-990 inliers). COLMAP then
# starts from a far-apart pair of 30-50 inliers whose two-view bundle adjustment cannot fix the
# focal length and distortion (lund: f 1035 -> 1505 px, k -4.9), and the model stops at two
# images. COLMAP still halves the angle and the inlier count (twice) if no pair qualifies.
RELAXED_INIT = {"mapper.init_max_forward_motion": 1.0, "mapper.init_min_tri_angle": 1.0}

# The last pass, when images are still left out: along a walk forward the points ahead are seen
# under angles below COLMAP's 1.5 degrees, so they are neither triangulated nor kept, and the
# next photo finds too few 2D-3D matches (30 inliers) to register, although it shares 100
# verified matches with its neighbour; COLMAP then starts a new model. lund at 504 px: 15 of
# 29 images in three models with RELAXED_INIT, all 29 in one with these (docs/history/pose.md).
LOOSE = {**RELAXED_INIT, "mapper.filter_min_tri_angle": 0.5, "triangulation.min_angle": 0.5,
         "mapper.abs_pose_min_num_inliers": 15}
PASSES = {"default": {}, "relaxed": RELAXED_INIT, "loose": LOOSE}
"""Mapping options of each pass over COLMAP's defaults (``<options group>.<field>``)."""


def _map(cfg: PoseConfig, db: Path, decoded: Path, out: Path, n: int,
         init: str = "default") -> dict:
    """Incremental mapping into ``out`` with the options of ``PASSES[init]``;
    {index: reconstruction}."""
    pycolmap = colmap_io.import_pycolmap()
    opts = pycolmap.IncrementalPipelineOptions()
    opts.num_threads = cfg.num_threads
    opts.random_seed = cfg.seed
    opts.mapper.random_seed = cfg.seed
    opts.triangulation.random_seed = cfg.seed
    for key, value in PASSES[init].items():
        group, field = key.split(".")
        setattr(getattr(opts, group), field, value)
    label = "pose: incremental mapping" + {"default": "", "relaxed": " (relaxed initial pair)",
                                           "loose": " (loose thresholds)"}[init]
    with make_progress() as prog:
        task = prog.add_task(label, total=n)
        return pycolmap.incremental_mapping(
            str(db), str(decoded), str(out), opts,
            initial_image_pair_callback=lambda: prog.advance(task, 2),
            next_image_callback=lambda: prog.advance(task, 1))


def needs_retry(registered: int, n: int, cfg: PoseConfig) -> bool:
    """Map again (relaxed) when fewer than half the images, or too few to pass, registered."""
    return registered < 3 or registered < max(0.5, cfg.min_registered_fraction) * n


def next_pass(done: str, registered: int, n: int, cfg: PoseConfig) -> str | None:
    """The pass to run after ``done`` when its best so far registered ``registered`` of
    ``n``: relaxed after default when ``needs_retry``, loose after either while images are
    left out (with ``loose_pass``), else None."""
    if done == "default" and needs_retry(registered, n, cfg):
        return "relaxed"
    if done != "loose" and cfg.loose_pass and registered < n:
        return "loose"
    return None


def run_passes(cfg: PoseConfig, n: int, map_pass, say=info) -> str:
    """Run the mapping passes in ``next_pass``'s order, ``map_pass(init)`` giving the images
    a pass registers (of ``n``); returns the pass kept: the one that registers the most, the
    earlier on a tie. ``say`` tells the user why a pass runs again."""
    kept, best, init = None, -1, "default"
    while init is not None:
        k = map_pass(init)
        if k > best:
            kept, best = init, k
        done, init = init, next_pass(init, best, n, cfg)
        if init == "relaxed":
            say(f"pose: only {k} of {n} images registered: mapping again with the initial "
                "pair relaxed for forward motion")
        elif init == "loose":
            say(f"pose: {best} of {n} images registered after the {done} pass: mapping "
                "again with lower triangulation-angle and inlier thresholds")
    return kept


def map_with_retry(cfg: PoseConfig, db: Path, decoded: Path, tmp: Path, n: int) -> tuple:
    """Incremental mapping, again with RELAXED_INIT and then LOOSE as ``next_pass`` says
    (``run_passes``).

    Returns ({index: reconstruction} of the kept pass, report entry
    {"passes": [{"init", "registered", "models"}, ...], "used": "default" | "relaxed" |
    "loose"}).
    """
    passes, recs = [], {}

    def map_pass(init: str) -> int:
        out = tmp / init
        out.mkdir(parents=True)
        recs[init] = _map(cfg, db, decoded, out, n, init)
        sizes = sorted((r.num_reg_images() for r in recs[init].values()), reverse=True)
        passes.append({"init": init, "registered": sizes[0] if sizes else 0, "models": sizes})
        return passes[-1]["registered"]

    kept = run_passes(cfg, n, map_pass)
    return recs[kept], {"passes": passes, "used": kept}


def solve(cfg: PoseConfig, ws: Workspace, inp: Inputs, resume: bool) -> tuple:
    """SfM on WS/decoded -> (largest reconstruction or None, all model sizes, timings)."""
    pycolmap = colmap_io.import_pycolmap()
    pycolmap.set_random_seed(cfg.seed)
    db = ws.colmap_db
    if not resume and db.exists():
        db.unlink()
    ws.colmap.mkdir(parents=True, exist_ok=True)
    names = [f"{s}.png" for s in inp.stems]
    t = {"start": time.time()}
    _import_images(cfg, db, ws.decoded, inp)
    _extract(cfg, db, ws.decoded, names)
    t["extract"] = time.time()
    matcher = choose_matcher(cfg, names)
    _match(cfg, db, matcher)
    t["match"] = time.time()
    tmp = ws.colmap / ".mapping"
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir()
    try:
        recs, mapping = map_with_retry(cfg, db, ws.decoded, tmp, len(names))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    t["map"] = time.time()
    secs = {"extract": t["extract"] - t["start"], "match": t["match"] - t["extract"],
            "map": t["map"] - t["match"]}
    sizes = sorted((r.num_reg_images() for r in recs.values()), reverse=True)
    return colmap_io.largest_model(recs), sizes, {"matcher": matcher, "mapping": mapping,
                                                  "seconds": secs}


# --------------------------------------------------------------------------- report
def registration_report(rec, inp: Inputs, model_sizes: list[int], extra: dict) -> dict:
    """Which images registered, with the model's statistics (saved as report.json)."""
    from pipeline.video_input import view_label

    reg = {Path(im.name).stem: im for im in colmap_io.registered_images(rec)} if rec else {}
    per = [{"name": view_label(s, inp.sources.get(s)), "stem": s, "registered": s in reg,
            "points3D": int(reg[s].num_points3D) if s in reg else 0} for s in inp.stems]
    return {
        "images": len(inp.stems), "registered": len(reg),
        "unregistered": [p["name"] for p in per if not p["registered"]],
        "num_points3D": int(rec.num_points3D()) if rec else 0,
        "mean_reprojection_error": float(rec.compute_mean_reprojection_error()) if rec else None,
        "mean_track_length": float(rec.compute_mean_track_length()) if rec else None,
        "models": model_sizes, **extra, "per_image": per,
    }


def print_report(report: dict) -> None:
    from rich.table import Table

    table = Table(title=f"pose: {report['registered']}/{report['images']} images registered")
    for col in ("image", "registered", "3D points seen"):
        table.add_column(col)
    for p in report["per_image"]:
        table.add_row(p["name"], "yes" if p["registered"] else "[red]no[/red]",
                      str(p["points3D"]))
    console.print(table)
    if report["registered"]:
        info(f"pose: {report['num_points3D']} points, mean reprojection error "
             f"{report['mean_reprojection_error']:.2f} px, models {report['models']}")


def check_registration(report: dict, cfg: PoseConfig, ws: Workspace) -> None:
    """Raise UserError when too few views registered; warn about the ones left out."""
    n, k, missing = report["images"], report["registered"], report["unregistered"]
    if k < 3 or k < cfg.min_registered_fraction * n:
        hint = ", try --matcher exhaustive" if report.get("matcher") == "sequential" else ""
        shown = ", ".join(missing[:12]) + (f" and {len(missing) - 12} more"
                                           if len(missing) > 12 else "")
        raise UserError(
            f"pose: only {k} of {n} images could be posed (not registered: {shown}): "
            "structure from motion needs overlapping photos of textured surfaces: take more "
            "photos 10-20 degrees apart with the same subject in view, avoid blur and plain "
            f"or shiny surfaces{hint}, or pass a reconstruction made "
            f"elsewhere with --colmap-model (details: {ws.colmap_report})")
    if missing:
        warn(f"pose: {len(missing)} image(s) not registered and left out: {', '.join(missing)}")


# --------------------------------------------------------------------------- outputs
def undistortion_map(cam) -> tuple:
    """(pinhole camera, [H, W] x map, [H, W] y map) for cv2.remap of one distorted camera.

    The maps give, for each pixel of the undistorted image, where to sample the distorted
    one (pixel centres at integers, as OpenCV; COLMAP's are at +0.5, hence the shifts).
    """
    pycolmap = colmap_io.import_pycolmap()
    pinhole = pycolmap.undistort_camera(pycolmap.UndistortCameraOptions(), cam)
    w, h = int(pinhole.width), int(pinhole.height)
    xs, ys = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    rays = pinhole.cam_from_img(np.c_[xs.ravel(), ys.ravel()])  # [H*W, 2] on z = 1
    uv = cam.img_from_cam(np.c_[rays, np.ones(len(rays))], check_cheirality=False) - 0.5
    return pinhole, *(uv[:, i].reshape(h, w).astype(np.float32) for i in (0, 1))


def undistort(rec, ws: Workspace) -> dict:
    """Undistort every registered WS/decoded image to PINHOLE into WS/images.

    Returns {image name: pinhole camera}. Images of a shared camera share one map.
    """
    import cv2

    images = colmap_io.registered_images(rec)
    maps, pinholes = {}, {}
    ws.images.mkdir(parents=True, exist_ok=True)
    with make_progress() as prog:
        task = prog.add_task("pose: undistort", total=len(images))
        for im in images:
            if im.camera_id not in maps:
                maps[im.camera_id] = undistortion_map(rec.cameras[im.camera_id])
            pinhole, mx, my = maps[im.camera_id]
            stem = Path(im.name).stem  # COLMAP's name of WS/decoded/<stem>.png
            src = read_image(ws.decoded_path(stem), bgr=True, fix=ws.rerun("decode"))
            out = cv2.remap(src, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
            atomic_imwrite(ws.image_path(stem), out)
            pinholes[im.name] = pinhole
            prog.advance(task)
    for p in ws.images.iterdir():
        if p.is_file() and p.name not in pinholes:
            p.unlink()
    return pinholes


def build_cameras(rec, pinholes: dict, inp: Inputs, margin: float) -> tuple[Cameras, np.ndarray]:
    """cameras.json content in the normalised frame, and the [N, 3] world points."""
    images = colmap_io.registered_images(rec)
    c2ws = {im.name: colmap_io.cam_to_world(im) for im in images}
    xyz, _ = colmap_io.all_points(rec)
    T = normalising_transform(np.stack([c[:3, 3] for c in c2ws.values()]), xyz)
    world = xyz @ T[:3, :3].T + T[:3, 3]
    frames = []
    for im in images:
        stem = Path(im.name).stem
        c2w = transform_c2w(T, c2ws[im.name])
        axis, center = c2w[:3, 2], c2w[:3, 3]
        fallback = near_far((world - center) @ axis, margin, (0.01, 10.0))
        seen = colmap_io.points_seen(rec, im) @ T[:3, :3].T + T[:3, 3]
        near, far = near_far((seen - center) @ axis, margin, fallback)
        ucam = pinholes[im.name]
        frames.append(Frame(
            name=inp.sources.get(stem, im.name), stem=stem, K=ucam.calibration_matrix(),
            width=int(ucam.width), height=int(ucam.height), c2w=c2w, near=near, far=far,
            colmap_camera=colmap_io.camera_dict(rec.cameras[im.camera_id])))
    return Cameras(frames=frames, colmap_to_world=T), world


class _ColmapLog:
    """Quiet COLMAP's glog output (errors only) unless asked for it."""

    def __init__(self, verbose: bool):
        self.verbose = verbose

    def __enter__(self):
        pycolmap = colmap_io.import_pycolmap()
        self.saved = pycolmap.logging.minloglevel
        pycolmap.logging.minloglevel = 0 if self.verbose else 2

    def __exit__(self, *exc):
        pycolmap = colmap_io.import_pycolmap()
        pycolmap.logging.minloglevel = self.saved


# --------------------------------------------------------------------------- stage
def _reconstruct(cfg: PoseConfig, ws: Workspace, inp: Inputs, resume: bool) -> tuple:
    """(reconstruction or None, model sizes, report extras): imported or solved."""
    if cfg.colmap_model:
        rec = colmap_io.import_model(cfg.colmap_model, inp.sizes)
        ws.colmap_db.unlink(missing_ok=True)
        return rec, [rec.num_reg_images()], {"matcher": "imported",
                                             "colmap_model": str(cfg.colmap_model)}
    return solve(cfg, ws, inp, resume)


def run(cfg: PoseConfig, ws: Workspace, force: bool = False) -> list[Path]:
    """Pose the decoded images of ``ws``; return the written paths."""
    validate(cfg)
    ws.require("decode")
    inp = Inputs.of(ws)
    choose_matcher(cfg, inp.stems)  # validate the option before any work
    params = {k: v for k, v in asdict(cfg).items() if k not in ("colmap_log", "num_threads")}
    extra_inputs = [Path(cfg.colmap_model).resolve()] if cfg.colmap_model else []
    stage_run = ws.begin_stage("pose", params, [ws.decoded, *extra_inputs], force,
                               defaults=asdict(PoseConfig()))
    if stage_run.skip:
        info(f"pose: up to date ({stage_run.previous.get('registered')} views posed)")
        return stage_run.outputs
    ws.colmap.mkdir(parents=True, exist_ok=True)
    with _ColmapLog(cfg.colmap_log):
        rec, model_sizes, extra = _reconstruct(cfg, ws, inp, ws.resumable(stage_run))
        report = registration_report(rec, inp, model_sizes, extra)
        atomic_write_json(ws.colmap_report, report)
        print_report(report)
        check_registration(report, cfg, ws)
        colmap_io.write_model(rec, ws.colmap_model)
    pinholes = undistort(rec, ws)
    cams, world = build_cameras(rec, pinholes, inp, cfg.depth_margin)
    write_cameras(ws, cams)
    _, rgb = colmap_io.all_points(rec)
    write_scene_glb(ws.scene_glb, world, rgb, cams.frames)
    info(f"pose: {len(cams.frames)} views -> {ws.cameras_json}, {ws.images}, {ws.scene_glb}")
    return stage_run.finish([ws.colmap, ws.images, ws.cameras_json, ws.scene_glb],
                       extra={"registered": report["registered"], "images": report["images"],
                              "matcher": report["matcher"]},
                       versions=["pycolmap", "trimesh"])
