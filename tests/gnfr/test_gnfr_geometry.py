"""Camera math of gnfr.geometry: round trips, sampling, bilinear lookup."""

from __future__ import annotations

import math

import torch

from gnfr.geometry import (
    image_pixels,
    inside_image,
    pixel_rays,
    project,
    relative_directions,
    sample_bilinear,
    sample_depths,
)


def _camera(seed: int) -> tuple[torch.Tensor, torch.Tensor]:
    g = torch.Generator().manual_seed(seed)
    K = torch.tensor([[300.0, 0, 161.0], [0, 290.0, 118.0], [0, 0, 1]], dtype=torch.float64)
    a = torch.randn(3, generator=g, dtype=torch.float64)
    S = torch.tensor([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    c2w = torch.eye(4, dtype=torch.float64)
    c2w[:3, :3] = torch.linalg.matrix_exp(S)
    c2w[:3, 3] = torch.randn(3, generator=g, dtype=torch.float64)
    return K, c2w


def test_pixel_ray_point_projects_back():
    K, c2w = _camera(0)
    pix = torch.rand(100, 2, dtype=torch.float64) * torch.tensor([320.0, 240.0])
    o, d = pixel_rays(K, c2w, pix)
    depth = torch.rand(100, dtype=torch.float64) * 5 + 0.5
    pts = o + depth[:, None] * d
    xy, z = project(pts, K[None], torch.linalg.inv(c2w)[None])
    assert torch.allclose(xy[0], pix, atol=1e-8)
    assert torch.allclose(z[0], depth, atol=1e-10)  # t is the camera z-depth


def test_pixel_centre_convention_reaches_image_corners():
    K, c2w = _camera(1)
    pix = image_pixels(2, 3).double()
    assert pix[0].tolist() == [0.5, 0.5] and pix[-1].tolist() == [2.5, 1.5]
    xy, depth = project(c2w[:3, 3][None] + c2w[:3, 2][None], K[None],
                        torch.linalg.inv(c2w)[None])
    assert torch.allclose(xy[0, 0], K[:2, 2])  # the optical axis hits the principal point
    assert bool(inside_image(xy, depth, (240, 320)).all())
    assert not bool(inside_image(xy, -depth, (240, 320)).any())  # behind the camera


def test_bilinear_sampling_hits_pixel_centres_at_any_resolution():
    img = torch.arange(12.0).reshape(1, 1, 3, 4)
    xy = torch.tensor([[[0.5, 0.5], [3.5, 2.5], [1.0, 0.5]]])
    out = sample_bilinear(img, xy, (3, 4))[0, :, 0]
    assert torch.allclose(out, torch.tensor([0.0, 11.0, 0.5]), atol=1e-5)
    # a half-resolution map of the same image extent is addressed with the same xy
    half = torch.tensor([[[[5.0]]]])
    assert torch.allclose(sample_bilinear(half, torch.tensor([[[2.0, 1.5]]]), (3, 4)),
                          torch.tensor([[[5.0]]]))


def test_depth_samples_uniform_in_disparity_and_ordered():
    near, far = torch.tensor([1.0, 2.0]), torch.tensor([10.0, 4.0])
    t = sample_depths(near, far, 8, jitter=False)
    disp = 1 / t
    steps = disp[:, 1:] - disp[:, :-1]
    assert torch.allclose(steps, steps[:, :1].expand_as(steps), atol=1e-6)
    g = torch.Generator().manual_seed(0)
    tj = sample_depths(near, far, 64, jitter=True, generator=g)
    assert bool((tj[:, 1:] > tj[:, :-1]).all())
    assert bool((tj >= near[:, None]).all()) and bool((tj <= far[:, None]).all())


def test_relative_direction_zero_for_the_same_camera():
    pts = torch.randn(4, 5, 3)
    centre = torch.tensor([[0.0, 0.0, -3.0]])
    rd = relative_directions(pts, centre.expand(4, 3), torch.cat([centre, -centre]))
    assert torch.allclose(rd[:, :, 0, 3], torch.ones(4, 5), atol=1e-5)  # dot of same dirs
    assert torch.allclose(rd[:, :, 0, :3], torch.zeros(4, 5, 3), atol=1e-5)
    assert torch.allclose(rd[:, :, 1, :3].norm(dim=-1), torch.ones(4, 5), atol=1e-4)
    assert not math.isnan(float(rd.sum()))
