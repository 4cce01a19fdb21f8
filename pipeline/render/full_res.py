"""Full-resolution de-flaring (``render --path inputs --full-res``) of the ORIGINAL photos.

For each input photo (read from the photo folder recorded in the manifest, EXIF orientation
applied) the flare region (the decoded-size mask warped through the camera model, scaled
up, dilated and feathered) is rendered with the view's COLMAP camera scaled to the
photo's size and blended into the photo. Which file each view came from, and whether it
is camera raw, is read from decode's record in the manifest (for a workspace whose record
does not list them: the file named in cameras.json, raw when its suffix is not one of
``pipeline.images.PHOTO_EXTS``). Output in ``WS/deflared_full/``:
- 8-bit JPEG input (``pipeline.images.JPEG_EXTS``) -> ``<stem>.jpg`` (quality 95) with the
  photo's EXIF (orientation reset to 1, since the pixels are stored upright);
- other input -> ``<stem>.png`` (16-bit for 16-bit input);
- raw input -> ``<stem>.tiff``, 16-bit LINEAR, blended into ``WS/linear/<stem>.tiff``:
  the render is linearised (inverse sRGB) and mapped to the camera's linear RGB with
  per-channel gains fitted on the clean pixels of the decoded photo. Without
  ``WS/linear/<stem>.tiff`` a raw photo is skipped with a message.
"""

from __future__ import annotations

import numpy as np

from pipeline.colour import srgb_to_linear
from pipeline.errors import UserError
from pipeline.images import JPEG_EXTS, is_photo, read_image
from pipeline.progress import warn
from pipeline.render.config import RenderConfig
from pipeline.render.flare_layer import apply_flare_layer
from pipeline.render.inputs import input_blend, input_rays, match_colours
from pipeline.render.jobs import FrameJob, FullRes, Prepared
from pipeline.video_input import is_video
from pipeline.workspace import Workspace
from pipeline.ws_files import read_decoded


def decoded_photos(ws: Workspace) -> tuple[dict[str, str], set[str] | None]:
    """From decode's record in the manifest: ({stem: photo file name}, raw stems). The raw
    stems are None when the record does not list them (a workspace made by hand)."""
    rec = ws.stage_record("decode")
    raw = rec.get("raw")
    return dict(rec.get("sources") or {}), (set(raw) if raw is not None else None)


def plan_full_res(ws: Workspace, jobs: list[FrameJob]) -> list[FrameJob]:
    """FrameJobs (into WS/deflared_full) for the input ``jobs`` whose photos can be
    de-flared at full resolution."""
    photos = ws.photos_dir
    if photos is None or not photos.is_dir():
        warn(f"--full-res: the photo folder {photos} recorded in the manifest is not there; "
             "skipping full-resolution output")
        return []
    names, raw = decoded_photos(ws)
    out, videos = [], set()
    for j in jobs:
        f = j.camera
        src = photos / names.get(f.stem, f.name)
        if is_video(src):  # a video's frame: the decoded frame is all there is
            videos.add(src.name)
            continue
        if not src.is_file():
            warn(f"--full-res: {src} is missing; {f.stem} skipped")
            continue
        is_raw = f.stem in raw if raw is not None else not is_photo(src)
        if is_raw:
            lin = ws.linear_path(f.stem)
            if not lin.is_file():
                warn(f"--full-res: {src.name} is a raw photo and {lin} is missing (decode "
                     "writes it for raw input); skipped")
                continue
            out.append(FrameJob(ws.deflared_full_path(f.stem, ".tiff"), j.sources, j.near,
                                j.far, f, FullRes(lin, linear=True)))
            continue
        jpeg = src.suffix.lower() in JPEG_EXTS
        out.append(FrameJob(ws.deflared_full_path(f.stem, ".jpg" if jpeg else ".png"),
                            j.sources, j.near, j.far, f,
                            FullRes(src, linear=False, exif=src if jpeg else None)))
    if videos:
        warn(f"--full-res: the frames of {', '.join(sorted(videos))} have no photo larger than "
             "WS/decoded (decode them with --max-size 0 for full size); skipped")
    return out


def linear_gains(linear: np.ndarray, decoded: np.ndarray, clean: np.ndarray) -> np.ndarray:
    """[3] per-channel gain g with linear ~ g * srgb_to_linear(decoded) on clean pixels.

    linear: [h, w, 3] float at the decoded size; decoded: [h, w, 3] float 0..1; clean:
    [h, w] bool (not flare)."""
    dec = srgb_to_linear(decoded, exact=True)
    ok = clean & np.all((decoded > 0.05) & (decoded < 0.95), -1)
    if ok.sum() < 100:
        ok = np.all(dec > 1e-3, -1)
    ratio = linear[ok] / np.maximum(dec[ok], 1e-6)
    return np.median(ratio, axis=0) if len(ratio) else np.ones(3)


def prepare_full_res(job: FrameJob, cfg: RenderConfig, ws: Workspace) -> Prepared:
    """The rays and compose of a full-resolution job (no depth guide: network fill only)."""
    import cv2

    f = job.camera
    full = job.full_res
    photo = read_image(full.photo, any_depth=True, fix="replace it, or render without --full-res")
    H, W = photo.shape[:2]
    decoded = read_decoded(ws, f.stem)
    dsize = (decoded.shape[1], decoded.shape[0])
    if abs(W / H - dsize[0] / dsize[1]) > 0.02:
        raise UserError(f"{full.photo} ({W}x{H}) does not have the aspect of "
                        f"{ws.decoded_path(f.stem)} {dsize}: {ws.rerun('decode')}")
    alpha, ring = input_blend(f, cfg, ws, (W, H), dsize)
    rays_o, rays_d, rows, cols = input_rays(f, alpha, W, H)
    ring_px = None if ring is None else ring[rows, cols]
    peak = 65535.0 if photo.dtype == np.uint16 else 255.0
    gains = np.ones(3)
    if full.linear:
        small = cv2.resize(photo.astype(np.float32) / peak, dsize, interpolation=cv2.INTER_AREA)
        clean = cv2.resize((alpha == 0).astype(np.uint8), dsize,
                           interpolation=cv2.INTER_NEAREST) > 0
        gains = linear_gains(small, decoded.astype(np.float32) / 255.0, clean)

    def compose(rgb):
        out = photo.astype(np.float32) / peak
        a = alpha[rows, cols, None]
        new = srgb_to_linear(rgb, exact=True) * gains if full.linear else rgb
        new = match_colours(new, out[rows, cols], ring_px)  # in the output's own encoding
        filled = out.copy()
        filled[rows, cols] = out[rows, cols] * (1 - a) + new * a
        filled = apply_flare_layer(out, filled, alpha, cfg, full.linear)
        return np.clip(np.rint(filled * peak), 0, peak).astype(photo.dtype)

    return Prepared(rays_o, rays_d, compose)
