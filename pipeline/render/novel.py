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
    K, w, h = low_res_camera(pc, net_scale)
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
        return to_u8(photos_over(up, colour, wgt, warped, net_scale, cfg.network_vote))

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
    K, w, h = low_res_camera(pc, net_scale)
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
        return to_u8(photos_over(up, colour, wgt, warped, net_scale, cfg.network_vote))

    return Prepared(rays_o, rays_d, compose, None, True)


def low_res_camera(pc, net_scale: float) -> tuple[np.ndarray, int, int]:
    """(K, w, h) of a path camera's frame at ``net_scale`` of its size (GN-FR's grid)."""
    W, H = pc.width, pc.height
    w, h = max(1, round(W * net_scale)), max(1, round(H * net_scale))
    K = np.asarray(pc.K, float).copy()
    K[0] *= w / W
    K[1] *= h / H
    return K, w, h


def photos_over(up: np.ndarray, colour: np.ndarray, wgt: np.ndarray, warped, net_scale: float,
                vote: float) -> np.ndarray:
    """The frame: the photos' agreed ``colour`` over GN-FR's upsampled render ``up`` by their
    weight ``wgt``, then (``vote`` > 0) a single photo where GN-FR vouches for it
    (``pipeline.photo_fill.network_vote``) on the pixels the photos left to GN-FR."""
    out = up * (1 - wgt[..., None]) + colour * wgt[..., None]
    if vote > 0 and warped is not None:
        from pipeline.photo_fill import network_vote, support_weight

        vc, vok = network_vote(up, warped, net_scale, vote)
        vw = (support_weight(vok & (wgt < 1), 0) * (1 - wgt))[..., None]
        out = out * (1 - vw) + vc * vw
    return out

