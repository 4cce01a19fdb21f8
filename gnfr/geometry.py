"""Camera math: pixel rays, projection into source views, sampling along rays.

Conventions (the whole of ``gnfr`` uses them):

* Cameras are OpenCV pinholes: ``c2w`` [4, 4] camera-to-world with x right, y down,
  z forward; ``K`` [3, 3] maps camera coordinates to *continuous* pixel coordinates in
  which the image spans ``[0, W] x [0, H]`` and the centre of pixel (column j, row i) is
  ``(j + 0.5, i + 0.5)`` (the COLMAP convention). Resizing an image by ``s`` therefore
  scales the first two rows of ``K`` by ``s`` exactly.
* A ray is ``o + t * d`` where ``d`` has camera-z component 1, so ``t`` is the z-depth in
  the ray's own camera; ``near``/``far`` are z-depths too.
* Bilinear sampling uses ``grid_sample(align_corners=False)``, which matches the
  continuous-coordinate convention above for images and for feature maps of any size.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F


def pixel_rays(K: torch.Tensor, c2w: torch.Tensor,
               pixels_xy: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Rays through continuous pixel coordinates.

    K: [3, 3]; c2w: [4, 4]; pixels_xy: [R, 2] (x, y) in the +0.5 convention: pass
    ``(j + 0.5, i + 0.5)`` for the centre of pixel (column j, row i).
    Returns rays_o [R, 3] (camera centre) and rays_d [R, 3] (world direction whose
    camera-z component is 1, not unit length).
    """
    K, c2w = K.to(pixels_xy), c2w.to(pixels_xy)
    ones = torch.ones_like(pixels_xy[:, :1])
    cam = torch.linalg.solve(K, torch.cat([pixels_xy, ones], 1).T).T  # [R, 3], z = 1
    rays_d = cam @ c2w[:3, :3].T
    rays_o = c2w[:3, 3].expand_as(rays_d)
    return rays_o, rays_d


def image_pixels(height: int, width: int, device=None) -> torch.Tensor:
    """[H*W, 2] pixel-centre coordinates (x, y), row-major."""
    ys, xs = torch.meshgrid(torch.arange(height, device=device, dtype=torch.float32) + 0.5,
                            torch.arange(width, device=device, dtype=torch.float32) + 0.5,
                            indexing="ij")
    return torch.stack([xs.reshape(-1), ys.reshape(-1)], 1)


def project(points: torch.Tensor, K: torch.Tensor,
            w2c: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Project world points into V cameras.

    points: [P, 3]; K: [V, 3, 3]; w2c: [V, 4, 4].
    Returns xy [V, P, 2] continuous pixel coordinates and depth [V, P] (camera z).
    """
    cam = points[None] @ w2c[:, :3, :3].transpose(1, 2) + w2c[:, None, :3, 3]  # [V, P, 3]
    depth = cam[..., 2]
    uvw = cam @ K.transpose(1, 2)
    z = uvw[..., 2:]
    z = torch.where(z.abs() < 1e-8, torch.full_like(z, 1e-8), z)
    xy = uvw[..., :2] / z
    return xy, depth


def sample_bilinear(maps: torch.Tensor, xy: torch.Tensor, size_hw: tuple[int, int]) -> torch.Tensor:
    """Bilinearly sample per-view maps at continuous pixel coordinates.

    maps: [V, C, h, w] (any resolution covering the image); xy: [V, P, 2] in pixels of an
    image of size ``size_hw`` = (H, W). Returns [V, P, C]; zeros outside the image.
    """
    H, W = size_hw
    scale = torch.tensor([2.0 / W, 2.0 / H], device=xy.device, dtype=xy.dtype)
    grid = (xy * scale - 1.0)[:, :, None, :].to(maps.dtype)  # [V, P, 1, 2]
    out = F.grid_sample(maps, grid, mode="bilinear", padding_mode="zeros", align_corners=False)
    return out[..., 0].transpose(1, 2)  # [V, P, C]


def inside_image(xy: torch.Tensor, depth: torch.Tensor, size_hw: tuple[int, int]) -> torch.Tensor:
    """[V, P] bool: projection inside [0, W] x [0, H] and in front of the camera.

    xy: [V, P, 2]; depth: [V, P].
    """
    H, W = size_hw
    x, y = xy[..., 0], xy[..., 1]
    return (depth > 1e-6) & (x >= 0) & (x <= W) & (y >= 0) & (y <= H)


def sample_depths(near: torch.Tensor, far: torch.Tensor, n_samples: int, jitter: bool,
                  generator: torch.Generator | None = None) -> torch.Tensor:
    """Depths uniform in inverse depth (disparity) between near and far.

    near, far: [R]. Returns t [R, S] increasing along S. With ``jitter`` each sample is
    drawn uniformly inside its disparity bin (stratified); without, bin centres are used.
    """
    R = near.shape[0]
    edges = torch.linspace(0.0, 1.0, n_samples + 1, device=near.device, dtype=near.dtype)
    lo, width = edges[:-1], edges[1:] - edges[:-1]
    if jitter:
        u = torch.rand(R, n_samples, generator=generator, device="cpu").to(near)
    else:
        u = torch.full((R, n_samples), 0.5, device=near.device, dtype=near.dtype)
    frac = lo + width * u  # [R, S] in (0, 1)
    inv_near, inv_far = 1.0 / near[:, None], 1.0 / far[:, None]
    return 1.0 / (inv_near * (1.0 - frac) + inv_far * frac)


def relative_directions(points: torch.Tensor, target_centers: torch.Tensor,
                        source_centers: torch.Tensor) -> torch.Tensor:
    """GNT/IBRNet relative-direction feature of each point in each source view.

    points: [R, S, 3]; target_centers: [R, 3] (ray origins); source_centers: [V, 3].
    Returns [R, S, V, 4]: unit (dir_to_target - dir_to_source) and their dot product.
    """
    to_tgt = F.normalize(target_centers[:, None, :] - points, dim=-1)[:, :, None]  # [R,S,1,3]
    to_src = F.normalize(source_centers[None, None] - points[:, :, None], dim=-1)  # [R,S,V,3]
    diff = to_tgt - to_src
    dot = (to_tgt * to_src).sum(-1, keepdim=True)
    unit = diff / diff.norm(dim=-1, keepdim=True).clamp_min(1e-6)
    return torch.cat([unit, dot], -1)
