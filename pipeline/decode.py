"""Decode stage: a folder of photos (camera raw or JPEG/PNG/TIFF) -> ``WS/decoded``.

Writes ``WS/decoded/<stem>.png`` (8-bit sRGB, orientation applied, long side at most
``max_size``) for every usable photo and, for camera raw input, ``WS/linear/<stem>.tiff``
(16-bit linear camera RGB after white balance, same size and orientation as the PNG). The
photo folder is only read.

Colour pipeline for camera raw (LibRaw through rawpy; every format LibRaw reads: DNG, NEF,
CR2/CR3, ARW, RAF, ORF, RW2, PEF, KDC, ...):

1. *Black and white level*: LibRaw subtracts the black level and scales the data so the
   white (saturation) level maps to full scale. Some files declare a white level below
   their own data (e.g. film-scanner NEFs declare 255 for 16-bit data, which would clip
   almost everything): then the white level is taken from the data (next ``2^k - 1`` above
   its maximum).
2. *White balance*: the camera's as-shot multipliers when the file has valid ones,
   otherwise LibRaw's daylight multipliers (``pre_mul``), otherwise none.
3. *Highlights*: LibRaw highlight mode "blend" (2): where one channel clipped, the clipped
   and unclipped channels are blended towards neutral, so clipped highlights stay white
   instead of turning magenta.
4. *Demosaic*: LibRaw AHD; when the raw is at least twice ``max_size`` on its long side,
   LibRaw's half-size mode (2x2 binning, no interpolation) is used instead: faster and
   sharper after downscaling.
5. *Exposure*: fixed (``no_auto_bright``, brightness 1): every view of a scene keeps the
   camera's exposure, so views stay photometrically consistent; nothing is auto-brightened.
6. *Linear output*: LibRaw's camera RGB (no colour matrix, gamma 1), 16-bit, resized with
   area averaging in linear light -> ``WS/linear/<stem>.tiff`` (RGB channel order).
7. *Display output*: LibRaw's camera-to-sRGB matrix (camera -> XYZ -> sRGB primaries, D65),
   gamma 1, resized in linear light, clipped to [0, 1], encoded with the sRGB transfer
   function (IEC 61966-2-1) and quantised to 8 bits -> ``WS/decoded/<stem>.png``.
   Orientation (the file's flip flag) is applied by LibRaw in both outputs.

JPEG/PNG/TIFF/BMP/WebP are read with OpenCV, which applies the EXIF orientation; 16-bit
images are scaled to 8 bits; images are resized with area averaging in their own (sRGB)
encoding. A JPEG without an end-of-image marker after its last scan is truncated and is
skipped (OpenCV would silently fill the missing part with grey).

Videos (MP4, MOV, MKV, ...: ``pipeline.video_input.VIDEO_EXTS``) give ``video_frames`` views
each, ``WS/decoded/<video stem>_f<index>.png``, chosen by ``pipeline.video_input`` (the
sharpest frame of each stretch of equal camera motion) and resized like photos; decode's
record in the manifest names each frame's video, index and time. A video sharing its stem
with a photo is a phone's Live Photo clip and is left out with a warning.

Two photos with one stem (a RAW+JPEG pair): the raw is kept and a warning names both.
Unreadable files are named in one line each and skipped; fewer than 3 usable photos is
an error. Per-file resume: outputs of an interrupted run with the same inputs and
parameters are kept, never an earlier finished run's of other settings
(``Workspace.kept``).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import asdict, dataclass
from functools import partial
from pathlib import Path
from typing import NamedTuple

import numpy as np

from pipeline.colour import linear_to_srgb
from pipeline.errors import UserError, shell_path
from pipeline.images import JPEG_EXTS, PHOTO_EXTS
from pipeline.options import option, validate
from pipeline.progress import info, make_progress, quiet_stderr, track, warn
from pipeline.video_input import VideoError, is_video
from pipeline.workspace import Workspace, atomic_imwrite, default_workspace

RAW_EXTS = frozenset({
    ".dng", ".nef", ".nrw", ".cr2", ".cr3", ".crw", ".arw", ".srf", ".sr2", ".raf", ".orf",
    ".rw2", ".rwl", ".pef", ".ptx", ".kdc", ".dcr", ".k25", ".srw", ".x3f", ".3fr", ".fff",
    ".iiq", ".mef", ".mos", ".mrw", ".erf", ".raw", ".dcs", ".cap", ".eip", ".gpr", ".ari",
    ".bay", ".rdc", ".sti", ".cs1", ".mdc"})
"""Camera raw extensions (read with LibRaw); ordinary images: ``pipeline.images.PHOTO_EXTS``."""
MIN_IMAGES = 3


@dataclass
class DecodeConfig:
    max_size: int = option(1008, ge=0)
    """Long side of the decoded images in pixels (never upscaled; 0 keeps the full size)."""
    highlight_mode: int = option(2, ge=0, le=9)
    """LibRaw highlight mode for raw input: 0 clip, 1 unclip, 2 blend, 3-9 rebuild."""
    video_frames: int = option(30, ge=1, le=5000)
    """Views taken from each video in the folder: the sharpest frame of each of this many
    stretches of equal camera motion (``pipeline.video_input``)."""


@dataclass
class Photo:
    """One photo chosen for decoding."""

    path: Path
    stem: str
    is_raw: bool
    others: tuple[Path, ...] = ()
    """Other files with the same stem, tried in order if ``path`` cannot be decoded."""
    video: bool = False
    """``path`` is a video: its chosen frames become views (``pipeline.video_input``)."""


NOT_READ = {".heic": "HEIC", ".heif": "HEIF", ".avif": "AVIF", ".jxl": "JPEG XL",
            ".jp2": "JPEG 2000", ".gif": "GIF", ".psd": "Photoshop", ".xcf": "GIMP"}
"""Image files a user may expect to be read that are not (the OpenCV of another machine may
not decode them): each is named in a warning with what to do."""


def not_read_warning(path: Path) -> str | None:
    """The warning for a file that looks like a photo but is not read, or None."""
    ext = path.suffix.lower()
    if ext in NOT_READ:
        return (f"skipping {path.name}: {NOT_READ[ext]} files are not read; export the photos "
                "as JPEG, PNG or TIFF (camera raw files are read as they are)")
    return None


def is_photo_file(path: Path) -> bool:
    """A file decode reads: camera raw or an ordinary image (any case), not hidden."""
    ext = path.suffix.lower()
    return path.is_file() and not path.name.startswith(".") and (
        ext in RAW_EXTS or ext in PHOTO_EXTS)


def photo_subfolders(folder: Path) -> list[tuple[Path, int]]:
    """(subfolder, photo count) of the folder's direct subfolders that hold photos (a
    camera's DCIM/100CANON), most photos first."""
    found = []
    for d in sorted(p for p in folder.iterdir() if p.is_dir() and not p.name.startswith(".")):
        n = sum(1 for f in d.iterdir() if is_photo_file(f))
        if n:
            found.append((d, n))
    return sorted(found, key=lambda dn: -dn[1])


# --------------------------------------------------------------------------- listing
def check_not_workspace(photos: Path) -> None:
    """A clear error when ``photos`` is a deflare-scene workspace or a folder inside one
    (its decoded photos would be decoded again into a workspace of their own)."""
    from pipeline.workspace import enclosing_workspace

    found = enclosing_workspace(photos)
    if found is None:
        return
    root, source = found
    if root == photos.resolve():
        src, ws = shell_path(source), shell_path(photos)
        raise UserError(f"{photos} is a deflare-scene workspace, not a photo folder: pass the "
                        f"photos it was made from, `deflare-scene decode {src} --out {ws}` "
                        f"(or `deflare-scene {ws}` to resume every stage)")
    raise UserError(f"{photos} is inside the deflare-scene workspace {root} (files it wrote): "
                    f"pass the photo folder it was made from, {source}")


def require_folder(photos: Path) -> None:
    """A clear error unless ``photos`` (which exists) is a folder; a video says where to
    put it."""
    if is_video(photos) and photos.is_file():
        raise UserError(f"{photos} is a video: put it in a folder of its own (e.g. "
                        f"{shell_path(photos.parent / photos.stem)}) and pass the folder; its "
                        "sharpest frames become the views")
    if not photos.is_dir():
        raise UserError(f"{photos} is not a folder: pass the folder that holds the photos")


def list_photos(photos: Path, video_frames: int = DecodeConfig.video_frames) -> list[Photo]:
    """The photos of a folder, one per stem (raw preferred), then its videos (each counted
    as ``video_frames`` views); clear errors when none."""
    if not photos.exists():
        raise UserError(f"photo folder {photos} does not exist: pass a folder of photos")
    require_folder(photos)
    entries = [p for p in photos.iterdir() if not p.name.startswith(".")]
    files = sorted(p for p in entries if p.is_file())
    if not entries:
        raise UserError(f"photo folder {photos} is empty: put at least {MIN_IMAGES} "
                        "overlapping photos of the scene in it")
    by_stem: dict[str, list[Path]] = {}
    for p in files:
        if is_photo_file(p):
            by_stem.setdefault(p.stem, []).append(p)
    not_read = 0
    for p in files:  # a HEIC beside a JPEG of the same stem (a phone's pair) is not missed
        if p.stem not in by_stem and (message := not_read_warning(p)) is not None:
            warn(message)
            not_read += 1
    videos = live_clips_left_out(files, [p for p in files if is_video(p)])
    inner = photo_subfolders(photos)
    if not by_stem and not videos:
        if inner:
            listed = ", ".join(f"{d.name} ({n} photos)" for d, n in inner[:4])
            raise UserError(f"photo folder {photos} has no photos of its own, its subfolders "
                            f"do ({listed}{', ...' if len(inner) > 4 else ''}): pass the one "
                            f"that holds this scene, e.g. {inner[0][0]}")
        named = f"; {not_read} file(s) in formats it does not read, named above" if not_read else ""
        raise UserError(f"photo folder {photos} has no photos (no camera raw such as DNG/NEF/"
                        f"CR2/ARW, no JPEG/PNG/TIFF files and no videos{named}): put the "
                        "photos of the scene in it")
    chosen = []
    for stem, paths in sorted(by_stem.items()):
        paths.sort(key=lambda p: (p.suffix.lower() not in RAW_EXTS, p.name))
        if len(paths) > 1:
            warn(f"{', '.join(p.name for p in paths)} share the stem '{stem}': "
                 f"using {paths[0].name} (the others only if it cannot be decoded)")
        chosen.append(Photo(paths[0], stem, paths[0].suffix.lower() in RAW_EXTS,
                            tuple(paths[1:])))
    chosen += [Photo(p, p.stem, False, video=True) for p in videos]
    chosen = without_copies(chosen)
    if inner:  # said, so a photo there is not thought used
        listed = ", ".join(f"{d.name}/ ({n})" for d, n in inner[:4])
        info(f"decode: photos in subfolders are left out, only {photos}'s own are used: "
             f"{listed}{', ...' if len(inner) > 4 else ''}")
    views = sum(video_frames if p.video else 1 for p in chosen)
    if views < MIN_IMAGES:
        enough = [(d, n) for d, n in inner if n >= MIN_IMAGES]
        hint = (f" (its subfolder {enough[0][0].name} holds {enough[0][1]}: pass "
                f"{enough[0][0]} if those are the scene)" if enough else "")
        raise UserError(f"photo folder {photos} has only {views} photo(s){hint}: at least "
                        f"{MIN_IMAGES} overlapping photos of the scene are needed")
    return chosen


def live_clips_left_out(files: list[Path], videos: list[Path]) -> list[Path]:
    """``videos`` without a phone's Live Photo clips (``IMG_1.MOV`` beside ``IMG_1.JPG`` or
    ``IMG_1.HEIC``: three seconds around one photo, not a walk), each named in a warning."""
    still = {p.stem for p in files if not is_video(p) and (
        is_photo_file(p) or p.suffix.lower() in NOT_READ)}
    kept = []
    for v in videos:
        if v.stem in still:
            warn(f"skipping {v.name}: it shares its name with a photo (a Live Photo's clip); "
                 "rename it to take its frames")
        else:
            kept.append(v)
    return kept


def without_copies(chosen: list[Photo]) -> list[Photo]:
    """``chosen`` without byte-identical copies of an earlier photo (``IMG_1 copy.jpg``
    beside ``IMG_1.jpg``), each named in a warning: a copy adds no view, and as a view of
    its own it would pair the photo with itself (zero baseline in the pose, a source that
    is its own target)."""
    import hashlib

    def digest(path: Path, limit: int | None = None) -> str:
        with path.open("rb") as f:
            return hashlib.sha256(f.read(limit) if limit else f.read()).hexdigest()

    by_start: dict[tuple[int, str], list[Photo]] = {}
    for photo in chosen:  # size, then the first MiB: one camera's raw files may share a size
        size = photo.path.stat().st_size
        if size:  # empty files: decoding names them as unreadable
            by_start.setdefault((size, digest(photo.path, 1 << 20) if size > 1 << 20 else ""),
                                []).append(photo)
    first: dict[str, Photo] = {}
    copies: set[str] = set()
    for same in by_start.values():
        if len(same) < 2:
            continue
        for photo in same:
            full = digest(photo.path)
            if full in first:
                warn(f"{photo.path.name} is the same file as {first[full].path.name}: "
                     "left out (a copy adds no view); remove it to silence this")
                copies.add(photo.stem)
            else:
                first[full] = photo
    return [p for p in chosen if p.stem not in copies]


# --------------------------------------------------------------------------- pixels
def target_size(w: int, h: int, max_size: int) -> tuple[int, int]:
    """(W, H) with the long side at most ``max_size``, aspect kept, never upscaled."""
    s = 1.0 if max_size <= 0 else min(1.0, max_size / max(w, h))
    return max(1, round(w * s)), max(1, round(h * s))


def resize_area(img: np.ndarray, max_size: int) -> np.ndarray:
    """Area-average downscale to the target size (identity when already small enough)."""
    import cv2

    h, w = img.shape[:2]
    W, H = target_size(w, h, max_size)
    return img if (w, h) == (W, H) else cv2.resize(img, (W, H), interpolation=cv2.INTER_AREA)


def jpeg_truncated(path: Path) -> bool:
    """True when the JPEG has no end-of-image marker after its last start-of-scan."""
    data = path.read_bytes()
    sos = data.rfind(b"\xff\xda")
    return sos < 0 or data.rfind(b"\xff\xd9") < sos


class DecodeError(Exception):
    """A photo that cannot be decoded (corrupt, truncated, unsupported)."""


def decode_image(path: Path, max_size: int) -> np.ndarray:
    """JPEG/PNG/TIFF/... -> [H, W, 3] uint8 BGR, EXIF orientation applied, resized."""
    import cv2

    if path.stat().st_size == 0:
        raise DecodeError("empty file (0 bytes)")
    if path.suffix.lower() in JPEG_EXTS and jpeg_truncated(path):
        raise DecodeError("truncated JPEG (no end-of-image marker)")
    # OpenCV's own warnings (a TIFF's extra samples, ...) are not the user's to read: the
    # stage names a file it cannot use in its own line
    cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_ERROR)
    img = cv2.imread(str(path), cv2.IMREAD_COLOR | cv2.IMREAD_ANYDEPTH)
    if img is None or img.size == 0:
        raise DecodeError("not a readable image (corrupt or unsupported)")
    if img.dtype == np.uint16:
        img = np.round(img.astype(np.float32) / 257.0)
    elif img.dtype != np.uint8:
        img = np.clip(img.astype(np.float32), 0, 1) * 255.0
    img = resize_area(img.astype(np.float32) if img.dtype != np.uint8 else img, max_size)
    return np.clip(np.round(img), 0, 255).astype(np.uint8) if img.dtype != np.uint8 else img


def _raw_params(raw, cfg: DecodeConfig) -> dict:
    """LibRaw parameters of steps 1-5 of the module docstring for one file."""
    import rawpy

    wb = list(raw.camera_whitebalance)[:3]
    params = dict(output_bps=16, gamma=(1, 1), no_auto_bright=True, bright=1.0,
                  highlight_mode=rawpy.HighlightMode(cfg.highlight_mode))
    if all(v > 0 for v in wb):
        params["use_camera_wb"] = True
    else:  # no valid as-shot multipliers: LibRaw falls back to its daylight pre_mul
        params["use_camera_wb"] = False
    data_max = int(raw.raw_image_visible.max())
    if data_max > raw.white_level:
        params["user_sat"] = int(2 ** int(np.ceil(np.log2(data_max + 1))) - 1)
    s = raw.sizes
    if cfg.max_size > 0 and max(s.width, s.height) >= 2 * cfg.max_size:
        params["half_size"] = True
    return params


def decode_raw(path: Path, cfg: DecodeConfig) -> tuple[np.ndarray, np.ndarray]:
    """Camera raw -> ([H, W, 3] uint8 sRGB BGR, [H, W, 3] uint16 linear camera RGB as BGR).

    Both arrays are in OpenCV's BGR order so ``cv2.imwrite`` stores them as RGB files.
    """
    import cv2
    import rawpy

    try:
        with quiet_stderr(), rawpy.imread(str(path)) as raw:
            params = _raw_params(raw, cfg)
            cam = raw.postprocess(output_color=rawpy.ColorSpace.raw, **params)
            srgb_lin = raw.postprocess(output_color=rawpy.ColorSpace.sRGB, **params)
    except (rawpy.LibRawError, ValueError, OSError) as e:
        msg = e.args[0].decode() if e.args and isinstance(e.args[0], bytes) else str(e)
        raise DecodeError(f"not a readable raw file ({msg})") from None
    cam = resize_area(cam.astype(np.float32), cfg.max_size)
    srgb = linear_to_srgb(resize_area(srgb_lin.astype(np.float32), cfg.max_size) / 65535.0,
                          exact=True)
    png = np.round(srgb * 255.0).astype(np.uint8)
    linear = np.clip(np.round(cam), 0, 65535).astype(np.uint16)
    return cv2.cvtColor(png, cv2.COLOR_RGB2BGR), cv2.cvtColor(linear, cv2.COLOR_RGB2BGR)


# --------------------------------------------------------------------------- stage
def _decode_one(photo: Photo, cfg: DecodeConfig, png: Path, tiff: Path) -> Photo:
    """Decode ``photo`` (or, if it fails, a same-stem alternative); return the one used.

    Raises DecodeError naming every file tried when none can be decoded.
    """
    errors = []
    for path in (photo.path, *photo.others):
        cand = Photo(path, photo.stem, path.suffix.lower() in RAW_EXTS)
        try:
            _decode_file(cand, cfg, png, tiff)
        except DecodeError as e:
            errors.append(f"{path.name}: {e}")
            continue
        if errors:
            warn(f"{errors[0]}; using {path.name} instead")
        return cand
    raise DecodeError("; ".join(errors))


def _decode_file(photo: Photo, cfg: DecodeConfig, png: Path, tiff: Path) -> None:
    if photo.is_raw:
        bgr, linear = decode_raw(photo.path, cfg)
        atomic_imwrite(tiff, linear)
    else:
        bgr = decode_image(photo.path, cfg.max_size)
    atomic_imwrite(png, bgr)


def _decode_video(path: Path, cfg: DecodeConfig, ws: Workspace, keep: Callable[[Path], bool],
                  taken_stems: set[str]) -> tuple[dict[str, dict], int]:
    """Choose and write the frames of one video (``pipeline.video_input``): ({stem: {video,
    frame, seconds}} of the frames written or kept, how many were kept from an interrupted
    run; ``keep``: whether a written frame is this run's, ``Workspace.kept``). Raises
    VideoError when the video cannot be read."""
    from pipeline import video_input as vi

    with make_progress() as prog:
        task = prog.add_task(f"decode {path.name}: scan", total=None)
        scan = vi.scan(path, lambda: prog.advance(task),
                       lambda n: prog.update(task, total=n or None))
        prog.update(task, total=len(scan.sharpness), completed=len(scan.sharpness))
        chosen = vi.choose(scan, cfg.video_frames)
        stems = {i: vi.frame_stem(path, i) for i in chosen}
        for stem in stems.values():
            if stem in taken_stems:
                raise UserError(f"frame {stem} of {path.name} has the name of another photo "
                                "in the folder: rename the video or that photo")
        todo = [i for i in chosen if not keep(ws.decoded_path(stems[i]))]
        if todo:
            task = prog.add_task(f"decode {path.name}: {len(todo)} frames", total=max(todo) + 1)
            for i, bgr in vi.read_chosen(path, todo, lambda: prog.advance(task)):
                atomic_imwrite(ws.decoded_path(stems[i]), resize_area(bgr, cfg.max_size))
        missing = [i for i in todo if not ws.decoded_path(stems[i]).exists()]
        if missing:  # the second pass ended early: the file changed or decodes unevenly
            raise VideoError(f"frame {missing[0]} could not be read again")
    fps = scan.fps if scan.fps > 0 else None
    info(f"{path.name}: {len(chosen)} of {len(scan.sharpness)} frames taken (the sharpest of "
         f"each stretch of equal camera motion)")
    return ({stems[i]: {"video": path.name, "frame": i,
                        "seconds": round(i / fps, 3) if fps else None} for i in chosen},
            len(chosen) - len(todo))


def _remove_stale(folder: Path, keep: set[str], path_of: Callable[[str], Path]) -> None:
    """Remove the per-view files of ``folder`` (those ``path_of(stem)`` names, e.g.
    ``Workspace.decoded_path``) whose stem is not in ``keep``."""
    if not folder.is_dir():
        return
    for p in folder.iterdir():
        if p.is_file() and p == path_of(p.stem) and p.stem not in keep:
            p.unlink()


class _Decoded(NamedTuple):
    """What one decode run made of the chosen files."""

    done: dict[str, Photo]
    """Stem -> the photo (or video) it came from."""
    skipped: dict[str, str]
    """File name -> why it could not be decoded."""
    reused: int
    """Images kept from an interrupted run."""
    frames: dict[str, dict]
    """Video frames taken: stem -> {video, frame, seconds}."""


def _decode_all(chosen: list[Photo], cfg: DecodeConfig, ws: Workspace,
                keep: Callable[[Path], bool]) -> _Decoded:
    """Decode the videos' frames, then the still photos, into ``ws``; a file that cannot be
    decoded is warned about and skipped."""
    done, skipped, reused, frames = {}, {}, 0, {}
    stills = [p for p in chosen if not p.video]
    for video in (p for p in chosen if p.video):
        try:
            taken, kept = _decode_video(video.path, cfg, ws, keep, set(done) | {
                p.stem for p in stills})
        except VideoError as e:
            warn(f"skipping {video.path.name}: {e}; replace or remove the file")
            skipped[video.path.name] = str(e)
            continue
        frames.update(taken)
        done.update({stem: video for stem in taken})
        reused += kept
    for photo in track(stills, "decode") if stills else ():
        png, tiff = ws.decoded_path(photo.stem), ws.linear_path(photo.stem)
        if keep(png) and (keep(tiff) or not photo.is_raw):
            done[photo.stem], reused = photo, reused + 1
            continue
        try:
            done[photo.stem] = _decode_one(photo, cfg, png, tiff)
        except DecodeError as e:
            warn(f"skipping {e}; replace or remove the file")
            skipped[photo.path.name] = str(e)
    return _Decoded(done, skipped, reused, frames)


def run(cfg: DecodeConfig, photos: str | os.PathLike, ws_path: str | os.PathLike | None = None,
        force: bool = False) -> Workspace:
    """Decode every photo of ``photos`` into the workspace ``ws_path``; return it."""
    validate(cfg)
    if cfg.max_size != 0 and cfg.max_size < 64:
        raise UserError(f"--max-size {cfg.max_size} is too small: use at least 64 pixels "
                        "(or 0 to keep the full size)")
    photos = Path(photos)
    check_not_workspace(photos)
    chosen = list_photos(photos, cfg.video_frames)
    ws_path = Path(ws_path or default_workspace(photos))
    made_here = not ws_path.exists()  # a failed first decode leaves no workspace behind
    ws = Workspace.create(ws_path, photos)
    stage_run = ws.begin_stage("decode", asdict(cfg), [photos.resolve()], force,
                                defaults=asdict(DecodeConfig()))
    if stage_run.skip:
        info(f"decode: up to date ({len(stage_run.previous.get('sources', {}))} images)")
        return ws
    keep = partial(ws.kept, stage_run)  # this run's file (an earlier run's of other settings: not)
    done, skipped, reused, frames = _decode_all(chosen, cfg, ws, keep)
    raw_stems = {s for s, p in done.items() if p.is_raw}
    if len(done) < MIN_IMAGES:  # before anything of an earlier run is removed
        what = (f"{len(done)} of {len(chosen)} photos" if not frames
                else f"{len(done)} views (photos and video frames)")
        if made_here:  # only this run's files are in it
            import shutil

            shutil.rmtree(ws.root, ignore_errors=True)
        raise UserError(f"only {what} in {photos} could be decoded (skipped: "
                        f"{', '.join(skipped) or 'none'}): at least {MIN_IMAGES} usable photos "
                        "are needed; replace the unreadable files")
    _remove_stale(ws.decoded, set(done), ws.decoded_path)
    _remove_stale(ws.linear, raw_stems, ws.linear_path)
    outputs = [ws.decoded] + ([ws.linear] if raw_stems else [])
    if not raw_stems and ws.linear.exists():
        import shutil

        shutil.rmtree(ws.linear)
    stage_run.finish(outputs, extra={
        "sources": {s: p.path.name for s, p in sorted(done.items())},
        "raw": sorted(raw_stems), "skipped": skipped, "video_frames": frames},
        versions=["rawpy", "opencv-contrib-python-headless", "numpy"])
    info(f"decode: {len(done)} images -> {ws.decoded}"
         + (f" ({reused} kept from an interrupted run)" if reused else "")
         + (f", {len(skipped)} skipped" if skipped else ""))
    return ws
