"""De-flared input photos: the flare mask warped and blended, fills colour-matched on its ring."""

from __future__ import annotations

import numpy as np

from pipeline.camera_models import CameraModel, warp_maps
from pipeline.cameras import Frame
from pipeline.errors import UserError, shell_path
from pipeline.render.config import INPUTS_FRAMES, RenderConfig
from pipeline.render.fill import fill_from_photos
from pipeline.render.flare_layer import apply_flare_layer
from pipeline.render.frames import to_u8
from pipeline.render.jobs import FrameJob, Prepared
from pipeline.workspace import Workspace
from pipeline.ws_files import (
    MASK_THRESHOLD,
    enclosed_holes,
    read_decoded,
    read_mask,
    read_view_image,
)


def prepare_input(job: FrameJob, cfg: RenderConfig, ws: Workspace,
                  photos: dict | None) -> Prepared:
    """An input view: the flare region (alpha > 0) filled by GN-FR or, in the hybrid fill,
    from the warped photos where they agree; each fill colour-matched on the ring."""
    frame = job.camera
    photo = read_decoded(ws, frame.stem)
    size = (photo.shape[1], photo.shape[0])
    alpha, ring = input_blend(frame, cfg, ws, size, size)
    region = alpha > 0.5 / 255
    wgt = colour = depth = rejected = None
    if photos is not None and region.any():
        colour, wgt, depth, rejected = input_photo_fill(job, cfg, ws, photos, photo, region,
                                                        ring)
    net = region if wgt is None else network_pixels(region, wgt, ring)
    rays_o, rays_d, rows, cols = input_rays(frame, net.astype(np.float32), *size)
    guided = None
    if depth is not None:
        import torch

        d = depth[rows, cols]
        known = (d > frame.near) & (d < frame.far)
        if not cfg.band_rejected:  # that depth shows another surface
            known &= ~rejected[rows, cols]
        guided = (torch.from_numpy(d), torch.from_numpy(known))

    def compose(rgb):
        out = photo.astype(np.float32) / 255.0
        fill = np.zeros_like(out)
        if len(rows):
            fill[rows, cols] = (match_colours(rgb, out[rows, cols], ring[rows, cols])
                                if ring is not None else rgb)
        if wgt is not None:
            pc = colour
            if ring is not None:
                pc = match_colours(colour.reshape(-1, 3), out.reshape(-1, 3),
                                   (ring & (wgt >= 1)).reshape(-1)).reshape(out.shape)
            fill = fill * (1 - wgt[..., None]) + pc * wgt[..., None]
        a = alpha[..., None]
        filled = np.where(region[..., None], out * (1 - a) + fill * a, out)
        return to_u8(apply_flare_layer(out, filled, alpha, cfg))

    return Prepared(rays_o, rays_d, compose, guided)


def input_photo_fill(job: FrameJob, cfg: RenderConfig, ws: Workspace, photos: dict,
                     photo: np.ndarray, region: np.ndarray, ring: np.ndarray | None):
    """(colour, weight, depth, rejected) of an input view's hybrid fill at the size of its
    decoded ``photo`` (uint8): the photos warped by depth (``fill_from_photos``, gains matched
    to the view's own clean pixels), brought to WS/decoded geometry, the ring check applied
    where there is a ``ring`` (``rejected``: the regions it turned down)."""
    frame = job.camera
    if cfg.inputs_fill == "frame":
        colour, wgt, depth = frame_fill(ws, frame)
    else:
        colour, wgt, depth, _ = fill_from_photos(frame.K, frame.c2w,
                                                 (frame.width, frame.height), job, photos,
                                                 cfg, own_clean_pixels(ws, frame))
    colour, wgt, depth = to_decoded(frame, (photo.shape[1], photo.shape[0]), colour, wgt,
                                    depth)
    rejected = np.zeros(region.shape, bool)
    if ring is not None:
        wgt, rejected = check_on_ring(colour, wgt, photo.astype(np.float32) / 255.0, region,
                                      ring)
    return colour, wgt, depth, rejected


def frame_fill(ws: Workspace, frame: Frame) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(colour, weight, depth) of an input view's fill for ``RenderConfig.inputs_fill``
    ``frame``: the novel frame drawn at its camera (WS/renders/inputs_frames/<stem>.png,
    resized to WS/images' size if it was drawn at another), weight 1 everywhere, no depth
    (GN-FR samples whole rays where the ring check turns the frame down)."""
    from pipeline.images import read_image_float

    path = ws.renders / INPUTS_FRAMES / f"{frame.stem}.png"
    colour = read_image_float(path, size=(frame.width, frame.height),
                              fix=f"render the de-flared photos again: {ws.rerun('render')}")
    size = colour.shape[:2]
    return colour, np.ones(size, np.float32), np.zeros(size, np.float32)


def network_pixels(region: np.ndarray, wgt: np.ndarray, ring: np.ndarray | None) -> np.ndarray:
    """[H, W] bool: the pixels of the flare ``region`` GN-FR renders in the hybrid fill: where
    the photos do not fully cover, and on the ring (its colour match)."""
    return region & ((wgt < 1) | (ring if ring is not None else False))


def own_clean_pixels(ws: Workspace, frame: Frame) -> tuple[np.ndarray, np.ndarray]:
    """(image float [H, W, 3], valid [H, W]) of WS/images/<stem>.png outside its flare mask
    grown by 2% of the long side: the reference the warped photos' gains are matched to.
    Without a mask (``blend none`` renders maskless views) every pixel is valid."""
    import cv2

    img = read_view_image(ws, frame.stem, as_float=True)
    if not ws.mask_path(frame.stem).exists():
        return img, np.ones(img.shape[:2], bool)
    flare = read_mask(ws, frame.stem)
    r = max(1, round(0.02 * max(flare.shape)))
    grown = cv2.dilate(flare.astype(np.uint8), np.ones((2 * r + 1, 2 * r + 1), np.uint8))
    return img, grown == 0


RING_TOLERANCE = 0.06
"""Largest mean absolute colour difference (0..1) between the photo fill and the clean photo
on a flare region's ring at which the photo fill of that region is trusted."""


def check_on_ring(colour: np.ndarray, wgt: np.ndarray, photo: np.ndarray, region: np.ndarray,
                  ring: np.ndarray, min_pixels: int = 20) -> tuple[np.ndarray, np.ndarray]:
    """(weight, rejected): the photo-fill weight with each connected flare region zeroed
    where the fill, on the region's ring (clean photo pixels just outside the mask), differs
    from the photo by more than RING_TOLERANCE on average: the warped photos there show
    another surface (a depth no photo confirms, or a surface the neighbours do not see), so
    the network fills it; ``rejected`` [H, W] bool marks those regions."""
    import cv2

    n, labels = cv2.connectedComponents(region.astype(np.uint8), connectivity=8)
    wgt = wgt.copy()
    rejected = np.zeros(region.shape, bool)
    err = np.abs(colour - photo).mean(-1)
    check = ring & (wgt >= 1)
    for k in range(1, n):
        sel = labels == k
        on = check & sel
        if on.sum() >= min_pixels and float(err[on].mean()) > RING_TOLERANCE:
            wgt[sel] = 0.0
            rejected |= sel
    return wgt, rejected


def to_decoded(frame: Frame, size: tuple[int, int], colour: np.ndarray, wgt: np.ndarray,
               depth: np.ndarray):
    """Colour, weight and depth from WS/images (pinhole) geometry into WS/decoded geometry
    (depth is z along the same rays, so it maps like the colour, without interpolation)."""
    import cv2

    cam = decoded_camera(frame, *size)
    pin = CameraModel.pinhole(frame.K, frame.width, frame.height)
    mx, my = warp_maps(pin, cam)
    colour = cv2.remap(colour, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
    wgt = cv2.remap(wgt, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                    borderValue=0)
    depth = cv2.remap(depth, mx, my, cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT,
                      borderValue=0)
    return colour, wgt, depth


MATCH_MIN_PIXELS = 100
MATCH_GAIN = (0.5, 2.0)


def match_colours(rgb: np.ndarray, photo: np.ndarray, ring: np.ndarray | None) -> np.ndarray:
    """Map rendered colours ``rgb`` [R, 3] to the photo: per channel, least squares
    ``photo ~ g * rgb + b`` over the ``ring`` [R] pixels (g clipped to MATCH_GAIN, b the
    mean residual with that g). Identity with fewer than MATCH_MIN_PIXELS ring pixels or
    ``ring`` None. Values stay in the input's range convention (clipped at 0 below)."""
    if ring is None or int(ring.sum()) < MATCH_MIN_PIXELS:
        return rgb
    x, y = rgb[ring].astype(np.float64), photo[ring].astype(np.float64)
    out = np.empty_like(rgb, dtype=np.float32)
    for c in range(rgb.shape[1]):
        xc, yc = x[:, c], y[:, c]
        var = float(np.var(xc))
        g = float(np.cov(xc, yc, bias=True)[0, 1] / var) if var > 1e-8 else 1.0
        g = float(np.clip(g, *MATCH_GAIN))
        b = float(np.mean(yc - g * xc))
        out[:, c] = g * rgb[:, c] + b
    return np.maximum(out, 0.0)


def input_blend(frame: Frame, cfg: RenderConfig, ws: Workspace, size: tuple[int, int],
                decoded_size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray | None]:
    """(alpha, ring) of an input view at ``size`` = (W, H) (the decoded framing, maybe
    scaled; ``decoded_size`` is WS/decoded's), from one read of its flare mask warped
    through the camera model. alpha [H, W]: the blend weight, the mask dilated and
    feathered (1 everywhere with blend none). ring [H, W] bool: the pixels the colour match
    is fitted on, rendered at full weight (alpha >= 0.9) but outside the flare mask (the
    dilation ring); None when colour matching is off (``color_match`` false or blend none).
    """
    import cv2

    if cfg.blend == "none":
        return np.ones(size[::-1], np.float32), None
    mask = flare_mask_in(decoded_camera(frame, *decoded_size), frame, ws)
    if decoded_size != size:  # full resolution: upsample the decoded-size mask
        mask = cv2.resize(mask.astype(np.uint8), size, interpolation=cv2.INTER_NEAREST) > 0
    alpha = blend_weights(mask, cfg.dilate, cfg.feather)
    return alpha, ((alpha >= 0.9) & ~mask) if cfg.color_match else None


def input_rays(frame: Frame, alpha: np.ndarray, width: int, height: int):
    """Rays [R, 3] (o, d) through the pixels with alpha > 0 of the view's full camera
    model at (width, height), and those pixels' rows, cols [R]."""
    import torch

    from gnfr.geometry import pixel_rays

    cam = decoded_camera(frame, width, height)
    rows, cols = np.nonzero(alpha > 0.5 / 255)
    xy = cam.pixel_to_normalized(np.stack([cols + 0.5, rows + 0.5], 1))
    rays_o, rays_d = pixel_rays(torch.eye(3), torch.tensor(frame.c2w, dtype=torch.float32),
                                torch.tensor(xy, dtype=torch.float32))
    return rays_o, rays_d, rows, cols


def decoded_camera(frame: Frame, width: int, height: int) -> CameraModel:
    """The full COLMAP camera of WS/decoded/<stem>.png (pinhole K if none is recorded)."""
    if frame.colmap_camera:
        cam = CameraModel.from_colmap(frame.colmap_camera)
    else:
        cam = CameraModel.pinhole(frame.K, frame.width, frame.height)
    if (cam.width, cam.height) != (width, height):
        cam = cam.scaled(width / cam.width, height / cam.height)
        cam.width, cam.height = width, height
    return cam


def require_masks(ws: Workspace, stems: list[str]) -> None:
    """A one-line error naming the first of ``stems`` without a WS/masks file (the
    de-flared photos blend by it), with what to run."""
    for stem in stems:
        path = ws.mask_path(stem)
        if not path.exists():
            raise UserError(f"{path} is missing: run `deflare-scene mask {shell_path(ws.root)}` "
                            "first, or render the full image with --blend none")


def flare_mask_in(cam: CameraModel, frame: Frame, ws: Workspace) -> np.ndarray:
    """[H, W] bool flare mask of WS/masks (WS/images geometry) warped into camera ``cam``:
    the mask as 0/255 grey, bilinearly remapped, cut at ``MASK_THRESHOLD`` (flare where more
    than half of the interpolated weight is)."""
    import cv2

    require_masks(ws, [frame.stem])
    flare = read_mask(ws, frame.stem)
    pin = CameraModel.pinhole(frame.K, flare.shape[1], flare.shape[0])
    mx, my = warp_maps(pin, cam)
    warped = cv2.remap(flare.astype(np.float32) * 255, mx, my, cv2.INTER_LINEAR,
                       borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    return warped > MASK_THRESHOLD


def blend_weights(mask: np.ndarray, dilate: float, feather: float) -> np.ndarray:
    """[H, W] float blend weight: 1 on the dilated mask, falling to 0 over the feather.

    Unmasked regions the mask encloses (the light source at the centre of its flare, which
    FMG and synth never mark) are kept at 0: dilation must not swallow the light.
    """
    import cv2

    long_side = max(mask.shape)
    r = max(1, round(dilate * long_side))
    grown = cv2.dilate(mask.astype(np.uint8),
                       cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1)))
    f = max(1, round(feather * long_side))
    # distance outside the grown mask -> linear ramp, so the weight is exactly 1 inside
    dist = cv2.distanceTransform((1 - grown).astype(np.uint8), cv2.DIST_L2, 5)
    weight = np.clip(1.0 - dist / f, 0.0, 1.0).astype(np.float32)
    holes = enclosed_holes(mask)
    if holes.any():
        weight[holes] = 0.0
    return weight
