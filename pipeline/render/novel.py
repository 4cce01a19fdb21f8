"""Novel frames: rays through a path camera, rendered whole or under the hybrid photo fill."""

from __future__ import annotations

import numpy as np

from pipeline.render.config import RenderConfig
from pipeline.render.fill import fill_from_photos
from pipeline.render.frames import to_u8
from pipeline.render.jobs import FrameJob, Prepared


def prepare_novel(job: FrameJob, cfg: RenderConfig, photos: dict | None,
                  net_scale: float) -> Prepared:
    """A novel frame: every pixel rendered by GN-FR (``photos`` None), or the hybrid fill
    (:func:`prepare_hybrid_novel`)."""
    import torch

    from gnfr.geometry import image_pixels, pixel_rays

    if photos is not None and cfg.network_depth != "off":
        return prepare_depth_first_novel(job, cfg, photos, net_scale)
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
    need = cv2.resize((wgt < 1).astype(np.float32), (w, h), interpolation=cv2.INTER_AREA) > 0
    need = cv2.dilate(need.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0  # for upsampling
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
        up = cv2.resize(low, (W, H), interpolation=cv2.INTER_LINEAR)
        out = up * (1 - wgt[..., None]) + colour * wgt[..., None]
        if warped is not None:
            from pipeline.photo_fill import network_vote, support_weight

            vc, vok = network_vote(up, warped, net_scale, cfg.network_vote)
            vw = (support_weight(vok & (wgt < 1), 0) * (1 - wgt))[..., None]
            out = out * (1 - vw) + vc * vw
        return to_u8(out)

    return Prepared(rays_o, rays_d, compose, (torch.from_numpy(d_lo), known))


def prepare_depth_first_novel(job: FrameJob, cfg: RenderConfig, photos: dict,
                              net_scale: float) -> Prepared:
    """A novel frame with ``cfg.network_depth``: GN-FR renders every pixel at ``net_scale``
    of the frame with its depth first; the photos are then warped through GN-FR's depth
    (upsampled; with ``holes`` only where the depth maps' depth does not reach) and drawn
    over GN-FR's upsampled render where they agree, as :func:`prepare_hybrid_novel` draws
    them."""
    import cv2
    import torch

    from gnfr.geometry import image_pixels, pixel_rays

    pc = job.camera
    H, W = pc.height, pc.width
    w, h = max(1, round(W * net_scale)), max(1, round(H * net_scale))
    K = np.asarray(pc.K, float).copy()
    K[0] *= w / W
    K[1] *= h / H
    rays_o, rays_d = pixel_rays(torch.tensor(K, dtype=torch.float32),
                                torch.tensor(pc.c2w, dtype=torch.float32), image_pixels(h, w))

    def compose(rgb, depth):
        prior = cv2.resize(depth.reshape(h, w).astype(np.float32), (W, H),
                           interpolation=cv2.INTER_LINEAR)
        colour, wgt, _, warped = fill_from_photos(pc.K, pc.c2w, (W, H), job, photos, cfg,
                                                  novel=True, prior_depth=prior,
                                                  prior_only=cfg.network_depth == "all")
        up = cv2.resize(rgb.reshape(h, w, 3).astype(np.float32), (W, H),
                        interpolation=cv2.INTER_LINEAR)
        out = up * (1 - wgt[..., None]) + colour * wgt[..., None]
        if cfg.network_vote > 0 and warped is not None:
            from pipeline.photo_fill import network_vote, support_weight

            vc, vok = network_vote(up, warped, net_scale, cfg.network_vote)
            vw = (support_weight(vok & (wgt < 1), 0) * (1 - wgt))[..., None]
            out = out * (1 - vw) + vc * vw
        return to_u8(out)

    return Prepared(rays_o, rays_d, compose, None, True)

