"""Novel frames: rays through a path camera, rendered whole or under the hybrid photo fill."""

from __future__ import annotations

import numpy as np

from pipeline.render.config import NOVEL_MATCH_MAX, NOVEL_MATCH_SIGMA, RenderConfig
from pipeline.render.fill import fill_from_photos
from pipeline.render.frames import to_u8
from pipeline.render.jobs import FrameJob, Prepared


def prepare_novel(job: FrameJob, cfg: RenderConfig, photos: dict | None,
                  net_scale: float) -> Prepared:
    """A novel frame: every pixel rendered by GN-FR (``photos`` None), or the hybrid fill
    (:func:`prepare_hybrid_novel`)."""
    import torch

    from gnfr.geometry import image_pixels, pixel_rays

    if photos is not None:
        return prepare_hybrid_novel(job, cfg, photos, net_scale)
    pc = job.camera
    H, W = pc.height, pc.width
    pix = image_pixels(H, W)
    rays_o, rays_d = pixel_rays(torch.tensor(pc.K, dtype=torch.float32),
                                torch.tensor(pc.c2w, dtype=torch.float32), pix)
    return Prepared(rays_o, rays_d, lambda rgb: to_u8(rgb.reshape(H, W, 3)))


def prepare_hybrid_novel(job: FrameJob, cfg: RenderConfig, photos: dict,
                         net_scale: float) -> Prepared:
    """A novel frame: the photos warped by depth at full frame size; GN-FR renders the
    pixels they do not cover at ``net_scale`` of the size (rays through the low-resolution
    pixel grid, sampled around the splatted depth where known), upsampled beneath them."""
    import cv2
    import torch

    from gnfr.geometry import image_pixels, pixel_rays

    pc = job.camera
    H, W = pc.height, pc.width
    colour, wgt, real_depth, warped = fill_from_photos(pc.K, pc.c2w, (W, H), job, photos,
                                                        cfg, novel=True)
    if cfg.network_vote <= 0:
        warped = None  # not kept for compose: only the vote reads the warped photos
    w, h = max(1, round(W * net_scale)), max(1, round(H * net_scale))
    K = np.asarray(pc.K, float).copy()
    K[0] *= w / W
    K[1] *= h / H
    # a low-res pixel is rendered when any full-res pixel it covers lacks the photos
    lacking = cv2.resize((wgt < 1).astype(np.float32), (w, h), interpolation=cv2.INTER_AREA) > 0
    need = cv2.dilate(lacking.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0  # for upsampling
    sel = torch.from_numpy(need.reshape(-1))
    rays_o, rays_d = pixel_rays(torch.tensor(K, dtype=torch.float32),
                                torch.tensor(pc.c2w, dtype=torch.float32),
                                image_pixels(h, w)[sel])
    d_lo = cv2.resize(real_depth, (w, h),
                      interpolation=cv2.INTER_NEAREST).reshape(-1)[need.reshape(-1)]
    known = torch.from_numpy((d_lo > job.near) & (d_lo < job.far))
    small_photo = cv2.resize(colour, (w, h), interpolation=cv2.INTER_AREA)

    def compose(rgb):
        low = small_photo.copy()
        low[need] = rgb
        low = match_network(low, need, lacking, colour, wgt, cfg.novel_match)
        up = cv2.resize(low, (W, H), interpolation=cv2.INTER_LINEAR)
        out = up * (1 - wgt[..., None]) + colour * wgt[..., None]
        if warped is not None:
            from pipeline.photo_fill import network_vote, support_weight

            vc, vok = network_vote(up, warped, net_scale, cfg.network_vote)
            vw = (support_weight(vok & (wgt < 1), 0) * (1 - wgt))[..., None]
            out = out * (1 - vw) + vc * vw
        return to_u8(out)

    return Prepared(rays_o, rays_d, compose, (torch.from_numpy(d_lo), known))


MATCH_FADE = 0.1
"""``novel_match`` ``local``: the offset applies in full where at least this share of the
Gaussian's weight falls on pixels it was fitted on, and fades to nothing where none does."""


def match_network(low: np.ndarray, need: np.ndarray, lacking: np.ndarray, colour: np.ndarray,
                  wgt: np.ndarray, mode: str) -> np.ndarray:
    """GN-FR's low-resolution frame ``low`` [h, w, 3] (its render at the ``need`` [h, w]
    pixels, the photos' elsewhere) with the rendered pixels brought to the photos' colours
    (``RenderConfig.novel_match``; ``off`` returns ``low``). Fitted where both exist at full
    size: the photos' pixels (``wgt`` [H, W] 1, ``colour`` [H, W, 3]) inside the low-res
    pixels ``lacking`` [h, w] the photos (where the upsampled frame is GN-FR's alone)."""
    if mode == "off":
        return low
    import cv2

    from pipeline.render.inputs import MATCH_MIN_PIXELS, apply_gains, fit_gains

    (h, w), (H, W) = need.shape, wgt.shape
    up = cv2.resize(low, (W, H), interpolation=cv2.INTER_LINEAR)
    inside = cv2.resize(lacking.astype(np.uint8), (W, H), interpolation=cv2.INTER_NEAREST) > 0
    fit = inside & (wgt >= 1)
    if int(fit.sum()) < MATCH_MIN_PIXELS:
        return low
    g, b = fit_gains(up[fit], colour[fit])
    out = low.copy()
    out[need] = apply_gains(low[need], g, b)
    if mode != "local":
        return out
    diff = colour - apply_gains(up.reshape(-1, 3), g, b).reshape(H, W, 3)
    usable = (fit & (np.abs(diff).max(axis=-1) <= NOVEL_MATCH_MAX)).astype(np.float32)
    # per low-res pixel: the share of its full-res pixels fitted on, and their mean difference
    share = cv2.resize(usable, (w, h), interpolation=cv2.INTER_AREA)
    summed = cv2.resize(diff * usable[..., None], (w, h), interpolation=cv2.INTER_AREA)
    sigma = max(1.0, NOVEL_MATCH_SIGMA * max(h, w))
    dens = cv2.GaussianBlur(share, (0, 0), sigma, borderType=cv2.BORDER_CONSTANT)
    num = cv2.GaussianBlur(summed, (0, 0), sigma, borderType=cv2.BORDER_CONSTANT)
    offset = np.clip(num / np.maximum(dens, 1e-6)[..., None], -NOVEL_MATCH_MAX, NOVEL_MATCH_MAX)
    offset *= np.clip(dens / MATCH_FADE, 0.0, 1.0)[..., None]
    out[need] = np.maximum(out[need] + offset[need], 0.0)
    return out
