"""Plane-sweep depth, depth splatting and photo warping (pipeline/stereo.py, photo_fill.py)."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.photo_fill import (
    close_small_holes,
    photo_fill,
    sharp_hole_weight,
    small_holes,
    support_weight,
)
from pipeline.stereo import (
    BEYOND_FAR,
    SGM_EDGE,
    PosedView,
    SweepConfig,
    aggregate_sgm,
    backproject,
    beyond_depths,
    consistency_count,
    homography,
    mean_of_smallest,
    nanmedian0,
    project_points,
    splat_depth,
    sweep_consensus,
    sweep_depth,
    warp_sources,
)
from tests.fixtures import look_at
from tests.fixtures import plane_views as fixture_plane_views

W, H = 160, 120
K = np.array([[150.0, 0, W / 2], [0, 150.0, H / 2], [0, 0, 1]])


FOUR = [[0.0, 0.0, -3.0], [0.35, 0.0, -3.0], [-0.35, 0.05, -3.0], [0.0, 0.3, -3.0]]
"""A reference camera and three neighbours around it, all looking at the plane."""


def plane_views(rng, centers):
    """PosedViews of a textured plane (tests.fixtures.plane_views) and the first view's true
    depth."""
    images, c2ws, depths = fixture_plane_views(rng, centers, K, (W, H))
    return [PosedView(img, K.copy(), m) for img, m in zip(images, c2ws, strict=True)], depths[0]


def test_homography_maps_plane_points():
    c2w_t, c2w_s = look_at([0.0, 0.0, -3.0]), look_at([0.4, 0.1, -3.0])
    d = 2.7
    Hm = homography(K, c2w_t, K, c2w_s, d)
    px = np.array([37.5, 80.5])  # continuous target pixel
    X = backproject(K, c2w_t, np.full((H, W), d, np.float32))[int(px[1]), int(px[0])]
    xy, _ = project_points(X[None], K, c2w_s)
    got = Hm @ np.array([px[0] - 0.5, px[1] - 0.5, 1.0])
    np.testing.assert_allclose(got[:2] / got[2] + 0.5, xy[0], atol=1e-3)


def test_sweep_recovers_a_textured_plane():
    rng = np.random.default_rng(0)
    views, true = plane_views(rng, FOUR)
    depth, conf = sweep_depth(views[0], views[1:], 2.0, 5.0, SweepConfig(planes=64, keep=2))
    known = depth > 0
    assert known.mean() > 0.7, "most of a textured plane must get a depth"
    rel = np.abs(depth[known] - true[known]) / true[known]
    assert np.median(rel) < 0.01, f"median relative depth error {np.median(rel):.4f}"
    assert conf[known].min() >= 0.5


def test_sweep_ignores_a_flared_neighbour():
    rng = np.random.default_rng(1)
    views, true = plane_views(rng, FOUR)
    flared = views[1]
    flared.image = flared.image.copy()
    flared.image[:, : W // 2] = 1.0  # a blown-out flare over half the neighbour
    flared.valid = np.ones((H, W), bool)
    flared.valid[:, : W // 2] = False
    depth, _ = sweep_depth(views[0], views[1:], 2.0, 5.0, SweepConfig(planes=64, keep=2))
    known = depth > 0
    rel = np.abs(depth[known] - true[known]) / true[known]
    assert known.mean() > 0.7 and np.median(rel) < 0.01


def test_warp_reproduces_a_source_at_its_own_camera():
    rng = np.random.default_rng(2)
    views, _ = plane_views(rng, [[0.0, 0.0, -3.0], [0.3, 0.0, -3.0]])
    src = views[1]
    src.depth = np.full((H, W), 3.0, np.float32)
    w = warp_sources(src.K, src.c2w, src.depth, [src])
    assert w.ok[0].all()
    np.testing.assert_allclose(w.colours[0], src.image, atol=1e-5)


def test_splat_and_fill_reproduce_a_neighbour_view():
    rng = np.random.default_rng(3)
    centers = [[0.0, 0.0, -3.0], [0.3, 0.0, -3.0], [-0.3, 0.0, -3.0]]
    views, true0 = plane_views(rng, centers)
    for v in views[1:]:
        v.depth, _ = sweep_depth(v, [u for u in views if u is not v], 2.0, 5.0,
                                 SweepConfig(planes=64))
    d = splat_depth(K, views[0].c2w, (W, H), views[1:])
    known = d > 0
    assert known.mean() > 0.6
    assert np.median(np.abs(d[known] - true0[known]) / true0[known]) < 0.01
    pf = photo_fill(K, views[0].c2w, (W, H), views[1:])
    ok = support_weight(pf.support, 2) >= 1
    assert ok.mean() > 0.4
    err = np.abs(pf.colour[ok] - views[0].image[ok]).mean()
    assert err < 0.03, f"mean abs colour error {err:.3f} where two photos agree"


def test_fill_has_no_support_where_every_neighbour_is_flared():
    rng = np.random.default_rng(4)
    views, _ = plane_views(rng, [[0.0, 0.0, -3.0], [0.3, 0.0, -3.0], [-0.3, 0.0, -3.0]])
    for v in views[1:]:
        v.depth = None
    for v in views[1:]:
        v.depth, _ = sweep_depth(v, [u for u in views if u is not v], 2.0, 5.0)
        v.valid = np.zeros((H, W), bool)
    pf = photo_fill(K, views[0].c2w, (W, H), views[1:])
    assert pf.support.max() == 0


@pytest.mark.parametrize("bad", [{"window": 4}, {"keep": 9}, {"planes": 1},
                                 {"sgm": (0.5, 0.1)}, {"sgm": (0.0, 1.0)},
                                 {"frames_sgm": (2.0, 1.0)}, {"frames_sgm": (0.0, 0.5)}])
def test_depth_config_rejects_bad_values(bad):
    from pipeline.depth import DepthConfig
    from pipeline.errors import UserError
    from pipeline.options import validate

    with pytest.raises(UserError, match="--"):
        validate(DepthConfig(**bad))


def test_few_depth_note_points_at_the_options_for_deep_scenes_only_when_depth_is_scarce():
    """The depth stage's note: under FEW_DEPTH of the pixels known (in the maps the video
    warps through) it names the opt-ins; none at or above it, nor when the looser check is
    already on."""
    from pipeline.depth import FEW_DEPTH, DepthConfig, few_depth_note

    note = few_depth_note(0.102, DepthConfig())
    assert note is not None and "(10%)" in note
    assert "depth.consistency_planes=1" in note and "render.network_depth=holes" in note
    assert few_depth_note(FEW_DEPTH, DepthConfig()) is None
    assert few_depth_note(0.05, DepthConfig(consistency_planes=1)) is None
    # the aggregation is named only where the video's maps are not aggregated already
    assert "depth.frames_sgm" not in note
    bare = few_depth_note(0.05, DepthConfig(frames_sgm=None))
    assert "depth.frames_sgm=0.1,1" in bare and "render.network_depth=holes" in bare
    assert "depth.frames_sgm" not in few_depth_note(0.05, DepthConfig(sgm=(0.1, 1.0),
                                                                      frames_sgm=None))


def test_close_small_holes_fills_specks_and_leaves_large_holes():
    """Specks and a thin crack of the agreed region take the colours around them; a hole
    wider than the radius stays the network's, and agreed pixels keep their colour."""
    rng = np.random.default_rng(0)
    h, w = 64, 96
    yy, xx = np.mgrid[0:h, 0:w]
    truth = np.stack([xx / w, yy / h, 0.5 + 0 * xx], -1).astype(np.float32)  # smooth ramp
    ok = np.ones((h, w), bool)
    specks = [(10, 10), (20, 50), (40, 30)]
    for y, x in specks:
        ok[y:y + 2, x:x + 2] = False
    ok[50, 5:60] = False                       # a one-pixel crack
    ok[5:35, 65:90] = False                    # a large hole: radius about 12 px
    colour = truth.copy()
    colour[~ok] = np.nan                       # what fuse leaves where the photos disagree
    colour[~ok & (rng.random((h, w)) < 0.5)] = 0.0
    out, ok2 = close_small_holes(colour, ok, radius=3.0)
    for y, x in specks:
        assert ok2[y, x] and np.abs(out[y, x] - truth[y, x]).max() < 0.03
    assert ok2[50, 5:60].all()
    assert not ok2[20, 77] and not ok2[5:35, 65:90].any()
    assert np.array_equal(out[ok], colour[ok])
    wt = support_weight(ok2, 0)
    assert wt[10, 10] == 1.0 and wt[20, 77] == 0.0
    same, same_ok = close_small_holes(colour, ok, radius=0.0)
    assert same is colour and same_ok is ok


def test_sharp_hole_weight_keeps_the_photos_around_small_holes_only():
    """A one-pixel hole takes a disc of the photos' weight with it under the feathered
    weight; with ``sharp_hole_weight`` only the hole itself is the network's. A hole wider
    than the radius still erodes and feathers the photos around it, exactly as before."""
    h, w = 64, 96
    ok = np.ones((h, w), bool)
    ok[20, 20] = False                          # a one-pixel hole
    ok[5:35, 60:90] = False                     # a large hole: radius about 15 px
    small = small_holes(ok, 2.0)
    assert small[20, 20] and small.sum() == 1
    feathered = support_weight(ok, 0)
    sharp = sharp_hole_weight(ok, 2.0)
    assert feathered[20, 22] < 1 and feathered[18, 20] < 1   # the disc around the hole
    assert sharp[20, 20] == 0.0
    ring = np.zeros((h, w), bool)
    ring[17:24, 17:24] = True
    ring[20, 20] = False
    assert (sharp[ring] == 1.0).all()
    far = np.zeros((h, w), bool)
    far[:, 45:] = True                          # around the large hole only
    assert np.array_equal(sharp[far], feathered[far])
    assert not small_holes(ok, 0.0).any()
    assert np.array_equal(sharp_hole_weight(ok, 0.5), support_weight(ok, 0))


def test_beyond_planes_reach_a_surface_past_the_far_bound():
    """A textured plane at 3 units, swept with a far bound of 1.5: the planes between the
    bounds cannot make the sources agree; planes past it (out to BEYOND_FAR x far) can."""
    d = beyond_depths(1.0, 8)
    assert len(d) == 8 and (np.diff(d) > 0).all() and d[0] > 1.0
    assert d[-1] == pytest.approx(BEYOND_FAR) and len(beyond_depths(1.0, 0)) == 0
    rng = np.random.default_rng(2)
    # fronto-parallel at depth 3; a plane past far=1.5 is at 2.97
    images, c2ws, depths = fixture_plane_views(rng, FOUR, K, (W, H), tilt=0.0)
    views = [PosedView(img, K.copy(), m) for img, m in zip(images, c2ws, strict=True)]
    true = depths[0]
    inner = (slice(20, -20), slice(20, -20))
    costs, errs = {}, {}
    for beyond in (0, 8):
        depth, cost = sweep_consensus(K, views[0].c2w, (W, H), views[1:], 0.8, 1.5,
                                      beyond=beyond)
        costs[beyond] = np.median(cost[inner])
        errs[beyond] = np.median(np.abs(depth[inner] - true[inner]) / true[inner])
    assert costs[8] < 0.5 * costs[0], costs
    assert errs[8] < 0.2 < errs[0], errs


def test_network_vote_takes_the_photo_that_agrees_with_the_network_sharp():
    """Two warped photos of a textured patch: one right, one offset in colour. The network
    saw only a blurred version (drawn at 1/4 size): the vote keeps the right photo's sharp
    pixels, never the wrong one's, and nothing where no photo is close to the network."""
    import cv2

    from pipeline.photo_fill import network_vote
    from pipeline.stereo import Warped

    rng = np.random.default_rng(5)
    H, W = 48, 64
    truth = cv2.resize(rng.uniform(0.2, 0.8, (12, 16, 3)).astype(np.float32), (W, H),
                       interpolation=cv2.INTER_NEAREST)  # sharp 4x4 blocks
    net = cv2.resize(cv2.resize(truth, (16, 12), interpolation=cv2.INTER_AREA), (W, H),
                     interpolation=cv2.INTER_LINEAR)
    wrong = np.clip(truth + 0.25, 0, 1)
    ok = np.ones((2, H, W), bool)
    ok[1, :, :8] = False  # the right photo does not see a strip: nothing there
    for order in ((wrong, truth), (truth, wrong)):
        w = Warped(np.stack(order), ok[::-1] if order[0] is truth else ok)
        colour, got = network_vote(net, w, 0.25, 0.1)
        right = w.ok[[k for k in (0, 1) if order[k] is truth][0]]
        inner = got & right
        assert inner.sum() > 0.8 * right.sum()
        assert np.abs(colour[inner] - truth[inner]).max() < 1e-6  # sharp, not the blur
        assert not (got & ~right).any()  # the wrong photo is never taken
    far = np.zeros_like(net)  # every photo is at least 0.2 away from it
    assert not network_vote(far, Warped(np.stack([truth, wrong]), ok), 0.25, 0.1)[1].any()


def test_remove_specks_drops_small_islands_and_keeps_surfaces():
    """Islands of depth smaller than the limit go (unknown), whatever their depth; a large
    surface, a slope whose depth changes smoothly, and a small patch joined to a surface
    within one plane step stay; unknown pixels stay unknown."""
    from pipeline.stereo import remove_specks

    near, far, planes = 1.0, 10.0, 48
    d = np.zeros((60, 80), np.float32)
    d[10:50, 10:40] = 3.0                                        # a surface
    d[10:50, 40:70] = np.linspace(3.0, 3.3, 30, dtype=np.float32)  # a slope joined to it
    d[2:5, 74:77] = 2.0                                           # a 9-pixel island
    d[55:57, 2:4] = 3.0                                           # 4 pixels, the surface's depth
    d[20:23, 20:23] = 1.2                                         # a speck on the surface
    out = remove_specks(d, near, far, planes, max_area=20)
    assert (out[2:5, 74:77] == 0).all() and (out[55:57, 2:4] == 0).all()
    assert (out[20:23, 20:23] == 0).all()
    keep = (d > 0).copy()
    keep[2:5, 74:77] = keep[55:57, 2:4] = keep[20:23, 20:23] = False
    assert np.array_equal(out[keep], d[keep]) and (out[~(d > 0)] == 0).all()
    assert remove_specks(d, near, far, planes, max_area=0) is d
    assert (remove_specks(d, near, far, planes, max_area=2500) == 0).all()  # 2,400 px


def test_photo_fallback_takes_farther_photos_only_where_the_nearest_disagree():
    """A camera among six photos of a plane; the four nearest are flared (invalid) over the
    left half of what it sees. Without the fallback no photo covers that half; with two more
    photos (the farther ones, clean there) it is covered with the plane's colours, and the
    right half, where the nearest agree, is the same pixels as without."""
    from pipeline.render.config import RenderConfig
    from pipeline.render.fill import fill_from_photos
    from pipeline.render.jobs import FrameJob
    from pipeline.render.plan import resolve_fill

    rng = np.random.default_rng(7)
    centers = [[0.0, 0.0, -3.0], [0.12, 0.0, -3.0], [-0.12, 0.0, -3.0], [0.0, 0.12, -3.0],
               [0.0, -0.12, -3.0], [0.45, 0.1, -3.0], [-0.45, -0.1, -3.0]]
    views, _ = plane_views(rng, centers)
    target, photos = views[0], views[1:]
    for v in photos:
        v.depth, _ = sweep_depth(v, [u for u in photos if u is not v], 2.0, 5.0,
                                 SweepConfig(planes=64))
    for v in photos[:4]:  # the nearest four: flared over the part the target sees on the left
        v.valid = np.ones((H, W), bool)
        v.valid[:, : W // 2 + 10] = False
    stems = [f"v{i}" for i in range(1, 7)]
    by = dict(zip(stems, photos, strict=True))
    job = FrameJob(out=None, sources=stems, near=2.0, far=5.0, camera=None)
    left = (slice(20, -20), slice(10, W // 2 - 20))
    right = (slice(20, -20), slice(W // 2 + 30, -20))
    fills = {fb: fill_from_photos(K, target.c2w, (W, H), job, by,
                                  resolve_fill(RenderConfig(photo_fallback=fb), "cpu", False))
             for fb in (0, 2)}
    assert fills[0].weight[left].mean() < 0.05
    assert fills[2].weight[left].mean() > 0.5
    covered = fills[2].weight[left] >= 1
    err = np.abs(fills[2].colour[left][covered] - target.image[left][covered]).mean()
    assert err < 0.05, err
    np.testing.assert_array_equal(fills[2].colour[right], fills[0].colour[right])
    np.testing.assert_array_equal(fills[2].weight[right], fills[0].weight[right])


def test_fuse_over_a_window_rejects_single_pixels_that_agree_by_chance():
    """Two sources agree with a third everywhere on the left; on the right the second
    source sees something else and matches the others at one pixel only (chance). Per pixel
    that pixel has the support of all three; over a 3 x 3 window only the two that agree
    around it count there, while the left keeps its three."""
    from pipeline.stereo import Warped, fuse

    rng = np.random.default_rng(5)
    h, w = 24, 32
    scene = rng.random((h, w, 3)).astype(np.float32)
    other = rng.random((h, w, 3)).astype(np.float32)
    b = scene.copy()
    b[:, w // 2:] = other[:, w // 2:]  # source b sees something else on the right ...
    b[12, 24] = scene[12, 24]          # ... but matches the scene at one pixel
    cols = np.stack([scene, scene + 0.01, b])
    ok = np.ones((3, h, w), bool)
    _, per_pixel = fuse(Warped(cols, ok), 0.08)
    _, windowed = fuse(Warped(cols, ok), 0.08, window=3)
    assert per_pixel[12, 24] == 3 and windowed[12, 24] == 2
    assert (windowed[4:-4, 2:w // 2 - 2] == 3).all()
    assert np.array_equal(fuse(Warped(cols, ok), 0.08, window=1)[1], per_pixel)


def test_min_margin_drops_matches_without_a_unique_plane():
    """Cameras side by side; a band of horizontal stripes (the same in every view) looks the
    same shifted along x, so every plane of the sweep matches it about equally well (the
    aperture problem): a confident but arbitrary depth, which the uniqueness test drops,
    while the textured plane keeps most of its depth, as accurate as without the test (a
    larger margin also drops right matches whose cost curve is broad: 0.05 keeps half of
    this smooth texture)."""
    rng = np.random.default_rng(11)
    views, true = plane_views(rng, [[0.0, 0.0, -3.0], [0.35, 0.0, -3.0], [-0.35, 0.0, -3.0],
                                    [0.2, 0.0, -3.0]])
    rows = np.arange(50, 70, dtype=np.float32)
    stripes = (0.5 + 0.4 * np.sin(2 * np.pi * rows / 6.0))[:, None, None]
    for v in views:
        v.image = v.image.copy()
        v.image[50:70] = stripes
    plain, _ = sweep_depth(views[0], views[1:], 2.0, 5.0, SweepConfig(planes=64, keep=2))
    strict, _ = sweep_depth(views[0], views[1:], 2.0, 5.0,
                            SweepConfig(planes=64, keep=2, min_margin=0.02))
    band, tex = (slice(54, 66), slice(20, -20)), (slice(10, 40), slice(20, -20))
    assert (plain[band] > 0).mean() > 0.8     # without the test the band gets depths ...
    assert (strict[band] > 0).mean() < 0.2    # ... that no plane wins clearly
    known = strict[tex] > 0
    assert known.mean() > 0.8
    rel = np.abs(strict[tex][known] - true[tex][known]) / true[tex][known]
    assert np.median(rel) < 0.01


@pytest.mark.parametrize("n", [1, 2, 3, 4, 5])
def test_nanmedian0_is_numpys_nanmedian_to_the_bit(n):
    """The sort-based median of a few sources gives np.nanmedian's values exactly: per-source
    holes (NaN on all channels, as warped photos have) and pixels no source sees."""
    import warnings

    rng = np.random.default_rng(n)
    c = rng.random((n, 40, 50, 3), dtype=np.float32)
    c[:, :, :10] = np.round(c[:, :, :10] * 4) / 4  # ties
    c[rng.random((n, 40, 50)) < 0.35] = np.nan
    c[:, :3] = np.nan  # seen by none
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        ref = np.nanmedian(c, axis=0)
    got = nanmedian0(c)
    assert got.dtype == ref.dtype and np.isnan(got[:3]).all()
    assert np.array_equal(got, ref, equal_nan=True)


@pytest.mark.parametrize("n", [1, 2, 3, 4, 6])
def test_mean_of_smallest_is_the_partition_mean_to_the_bit(n):
    """Best-k costs: the mean of the ``keep`` smallest along the first axis, every keep
    (all of them: their plain mean, in their order)."""
    rng = np.random.default_rng(10 + n)
    v = rng.random((n, 30, 40), dtype=np.float32) * 2
    v[:, :, :8] = np.round(v[:, :, :8] * 2) / 2  # ties
    for keep in range(1, n + 2):
        ref = np.partition(v, keep - 1, axis=0)[:keep].mean(0) if keep < n else v.mean(0)
        got = mean_of_smallest(v, keep)
        assert got.dtype == np.float32 and np.array_equal(got, ref), keep


def test_consensus_cost_is_the_windowed_variance_of_the_valid_sources():
    """One plane: the cost is the box-averaged colour variance (mean over channels) of the
    sources warped through it, each left out where it is flared; infinite where fewer than
    two see a pixel."""
    import cv2

    rng = np.random.default_rng(5)
    views, _ = plane_views(rng, [[0.0, 0.0, -2.0], [0.3, 0.0, -2.0], [-0.3, 0.05, -2.0],
                                 [0.0, 0.25, -2.0]])
    views[2].valid = np.ones((H, W), bool)
    views[2].valid[30:90, 40:120] = False  # a flared patch
    near = 1.5
    _, cost = sweep_consensus(K, views[0].c2w, (W, H), views[1:], near, 4.0, planes=1,
                              window=5)
    warped, seen = [], []
    for v in views[1:]:
        Hm = homography(K, views[0].c2w, v.K, v.c2w, near)
        flags = cv2.WARP_INVERSE_MAP
        warped.append(cv2.warpPerspective(v.image, Hm, (W, H), flags=cv2.INTER_LINEAR | flags))
        ok = np.ones((H, W), np.uint8) if v.valid is None else v.valid.astype(np.uint8)
        seen.append(cv2.warpPerspective(ok, Hm, (W, H), flags=cv2.INTER_NEAREST | flags) > 0)
    stack = np.where(np.array(seen)[..., None], np.array(warped, np.float64), np.nan)
    count = np.array(seen).sum(0)
    var = np.nanvar(stack, axis=0).mean(-1)
    ref = cv2.blur(np.where(count >= 2, var, 1.0), (5, 5))
    both = count >= 2
    assert both.mean() > 0.5 and (~both).any()
    assert np.isinf(cost[~both]).all()
    np.testing.assert_allclose(cost[both], ref[both], atol=2e-6)


def test_consistency_in_inverse_depth_accepts_what_the_relative_check_rejects():
    """Two views of a plane, the neighbour's depth 4 % too far: the relative check at 2 %
    rejects every pixel, an inverse-depth tolerance of 0.02 (at depth 3, about 6 % of z)
    keeps them, one of 0.005 (1.5 %) does not; pixels without depth never count."""
    rng = np.random.default_rng(1)
    views, true = plane_views(rng, [[0.0, 0.0, -3.0], [0.3, 0.0, -3.0]])
    _, true1 = plane_views(np.random.default_rng(1), [[0.3, 0.0, -3.0], [0.0, 0.0, -3.0]])
    views[0].depth = true.astype(np.float32)
    views[1].depth = (true1 * 1.04).astype(np.float32)
    views[0].depth[:10] = 0
    seen = consistency_count(views, 0, [1], 0.5)[10:] > 0  # what the neighbour sees at all
    assert seen.mean() > 0.5
    assert not consistency_count(views, 0, [1], 0.02).any()
    wide = consistency_count(views, 0, [1], 0.02, inverse_tol=0.02)
    assert (wide[10:][seen] == 1).mean() > 0.95 and not wide[:10].any()
    assert not consistency_count(views, 0, [1], 0.02, inverse_tol=0.005).any()


@pytest.mark.filterwarnings("ignore:All-NaN slice:RuntimeWarning")  # fuse where one photo is out
def test_harmonize_sources_takes_out_smooth_differences_and_keeps_other_surfaces():
    """Three warped photos of one textured surface, two with a smooth brightness ramp of
    their own (vignetting, a sky's gradient): harmonized, each is within a small error of
    the median photo wherever it saw the surface, so the fused colour no longer jumps where
    a photo drops out of the set; a square where one photo sees another surface (0.4
    brighter) is left as it was, and a lone photo (nothing to compare with) is unchanged."""
    import cv2

    from pipeline.stereo import HARMONIZE_MAX, Warped, fuse, harmonize_sources

    rng = np.random.default_rng(3)
    H, W = 60, 80
    truth = cv2.resize(rng.uniform(0.2, 0.6, (15, 20, 3)).astype(np.float32), (W, H),
                       interpolation=cv2.INTER_NEAREST)
    ramp = np.linspace(0.0, 0.12, W, dtype=np.float32)[None, :, None] * np.ones((H, 1, 1))
    cols = np.stack([truth, truth + ramp, truth + 0.5 * ramp]).astype(np.float32)
    median = cols[2].copy()  # the middle photo at every pixel
    cols[2, 20:30, 30:40] += 0.4  # photo 2 sees something else there
    ok = np.ones((3, H, W), bool)
    out = harmonize_sources(Warped(cols.copy(), ok), sigma=4.0)
    inner = np.zeros((H, W), bool)
    inner[8:-8, 8:-8] = True  # away from the frame's border
    inner[8:42, 18:52] = False  # and from the other surface (which moves the median)
    for k in (0, 1):
        assert np.abs(cols[k] - median)[inner].max() > 0.035
        assert np.abs(out.colours[k] - median)[inner].max() < 0.01
    other = out.colours[2, 22:28, 32:38] - median[22:28, 32:38]
    assert other.min() > HARMONIZE_MAX  # the other surface is not pulled to the median
    lone = Warped(cols[:1].copy(), ok[:1])
    assert np.array_equal(harmonize_sources(lone, 4.0).colours, cols[:1])
    # fused, the colour does not jump where the nearest photo drops out of the set
    part = ok.copy()
    part[0, :, :60] = False  # the nearest photo does not see the left part

    def step(w):  # the fused colour's error from the truth, across column 60
        e = fuse(w)[0] - truth
        return np.abs(e[8:-8, 60] - e[8:-8, 59]).max()

    assert step(Warped(cols, part)) > 0.03
    assert step(harmonize_sources(Warped(cols.copy(), part), 4.0)) < 0.01



def test_photo_fill_through_a_prior_depth():
    """photo_fill through a given depth (``prior_depth``): with ``prior_only`` and the true
    depth of the camera, the neighbours agree on most pixels and reproduce its photo; through
    a depth 30 % too far they agree on far fewer; without ``prior_only`` the prior only
    fills where the splatted depth maps do not reach (none here: none are given)."""
    rng = np.random.default_rng(3)
    centers = [[0.0, 0.0, -3.0], [0.3, 0.0, -3.0], [-0.3, 0.0, -3.0]]
    views, true0 = plane_views(rng, centers)
    true0 = true0.astype(np.float32)
    good = photo_fill(K, views[0].c2w, (W, H), views[1:], prior_depth=true0, prior_only=True)
    ok = support_weight(good.support, 2) >= 1
    assert ok.mean() > 0.6
    assert np.abs(good.colour[ok] - views[0].image[ok]).mean() < 0.03
    assert np.array_equal(good.depth, true0)
    far = photo_fill(K, views[0].c2w, (W, H), views[1:], prior_depth=1.3 * true0,
                     prior_only=True)
    assert (far.support >= 2).mean() < 0.5 * (good.support >= 2).mean()
    holes = photo_fill(K, views[0].c2w, (W, H), views[1:], prior_depth=true0, dense=False)
    assert np.array_equal(holes.depth, true0)  # no view has a depth map: all holes


def _sgm_by_loops(cost, grey, p1, p2):
    """Hirschmueller's recursion written pixel by pixel: the reference for aggregate_sgm."""
    P, Hh, Ww = cost.shape
    total = np.zeros_like(cost)
    for axis, step in ((0, 1), (0, -1), (1, 1), (1, -1)):
        n_lines, n_steps = (Hh, Ww) if axis == 0 else (Ww, Hh)
        for line in range(n_lines):
            order = range(n_steps) if step > 0 else range(n_steps - 1, -1, -1)
            prev, last = None, None
            for k in order:
                y, x = (line, k) if axis == 0 else (k, line)
                if prev is None:
                    cur = cost[:, y, x].copy()
                else:
                    ly, lx = (line, last) if axis == 0 else (last, line)
                    pen = max(p2 / (1 + abs(grey[y, x] - grey[ly, lx]) / SGM_EDGE), p1)
                    m = prev.min()
                    cur = np.empty(P, np.float32)
                    for d in range(P):
                        best = min(prev[d], m + pen)
                        if d > 0:
                            best = min(best, prev[d - 1] + p1)
                        if d < P - 1:
                            best = min(best, prev[d + 1] + p1)
                        cur[d] = cost[d, y, x] + best - m
                total[:, y, x] += cur
                prev, last = cur, k
    return total


def test_sgm_aggregation_is_the_recursion_along_four_scanlines():
    rng = np.random.default_rng(3)
    cost = rng.random((6, 5, 7)).astype(np.float32) * 2
    grey = rng.random((5, 7)).astype(np.float32)
    got = aggregate_sgm(cost, grey, 0.1, 0.8)
    np.testing.assert_allclose(got, _sgm_by_loops(cost, grey, 0.1, 0.8), atol=1e-5)
    # each scanline's term lies in [C, C + P2]
    assert (got >= 4 * cost - 1e-5).all() and (got <= 4 * (cost + 0.8) + 1e-5).all()


def test_sgm_gives_a_textureless_band_its_neighbours_depth():
    rng = np.random.default_rng(0)
    views, true = plane_views(rng, FOUR)
    ref = views[0]
    ref.image = ref.image.copy()
    ref.image[:, 64:96] = 0.5  # no texture in the reference: every plane matches as badly
    band = np.zeros((H, W), bool)
    band[10:-10, 70:90] = True  # the band's windows away from its edges
    own, _ = sweep_depth(ref, views[1:], 2.0, 5.0, SweepConfig(planes=64))
    agg, conf = sweep_depth(ref, views[1:], 2.0, 5.0, SweepConfig(planes=64, sgm=(0.1, 1.0)))
    assert (own[band] > 0).mean() < 0.05, "a flat window has no depth of its own"
    known = band & (agg > 0)
    assert known.sum() > 0.8 * band.sum(), "the band takes its neighbours' depth"
    # the plane is tilted and the band 32 pixels wide: its depth is carried in from either
    # side nearly constant, a few percent off the truth (near or far bound: 30-70 %); a
    # few rows take a wrong depth along a scanline (SGM's streaks)
    rel = np.abs(agg[known] - true[known]) / true[known]
    assert (rel < 0.06).mean() > 0.8, f"{(rel < 0.06).mean():.3f} within 6 %"
    assert np.median(rel) < 0.05, f"median relative depth error {np.median(rel):.4f}"
    textured = ~np.zeros((H, W), bool)
    textured[:, 56:104] = False
    both = textured & (own > 0) & (agg > 0)
    assert both.mean() > 0.5
    assert np.median(np.abs(agg[both] - true[both]) / true[both]) < 0.01


def test_the_depth_stage_writes_the_novel_frames_maps_as_an_aggregated_run_would(tmp_path):
    """By default the depth stage writes WS/depth as it did without ``frames_sgm`` and
    WS/depth/frames as the stage run with ``--sgm`` writes WS/depth (bit for bit: the
    novel frames' maps are what the rule judged); with ``--frames-sgm none`` the folder of
    an earlier run is gone; with ``frames_sgm`` equal to ``sgm`` none is written."""
    import shutil

    from pipeline.depth import DepthConfig, run
    from pipeline.workspace import Workspace
    from pipeline.ws_files import read_depth
    from tests.fixtures import make_plane_workspace

    ws = make_plane_workspace(tmp_path / "ws", n_views=4)
    plain = Workspace(shutil.copytree(ws.root, tmp_path / "plain"))
    aggregated = Workspace(shutil.copytree(ws.root, tmp_path / "aggregated"))
    run(DepthConfig(neighbours=3), ws)
    run(DepthConfig(neighbours=3, frames_sgm=None), plain)
    run(DepthConfig(neighbours=3, sgm=(0.1, 1.0), frames_sgm=None), aggregated)
    stems = sorted(p.stem for p in ws.images.glob("*.png"))
    assert sorted(p.stem for p in ws.depth_frames.glob("*.npz")) == stems
    assert not plain.depth_frames.exists() and not aggregated.depth_frames.exists()
    differ = 0
    for s in stems:
        main, frames = read_depth(ws, s), read_depth(ws, s, ws.depth_path(s, frames=True))
        for a, b in zip(main, read_depth(plain, s), strict=True):
            assert np.array_equal(a, b), s
        for a, b in zip(frames, read_depth(aggregated, s), strict=True):
            assert np.array_equal(a, b), s
        differ += int(not np.array_equal(main[0], frames[0]))
    assert differ > 0, "the aggregation changed no map"
    assert ws.stage_record("depth")["coverage_frames"] > 0
    assert not any(p.name.startswith(".raw") for p in ws.depth.iterdir())
    run(DepthConfig(neighbours=3, frames_sgm=None), ws)
    assert not ws.depth_frames.exists()
    run(DepthConfig(neighbours=3, sgm=(0.1, 1.0)), ws)
    assert not ws.depth_frames.exists()


def test_the_depth_stage_takes_both_maps_from_one_cost_volume_per_view(tmp_path, monkeypatch):
    """Without the mask stage's sweeps each view's costs are swept once for both its maps;
    a run killed after the first pass resumes without sweeping again and writes the same
    maps as one run straight through."""
    import shutil

    from pipeline import depth
    from pipeline.workspace import Workspace
    from pipeline.ws_files import read_depth
    from tests.fixtures import make_plane_workspace

    ws = make_plane_workspace(tmp_path / "ws", n_views=4)
    killed = Workspace(shutil.copytree(ws.root, tmp_path / "killed"))
    calls = []
    real = depth.sweep_depths

    def counted(ref, *a, **k):
        calls.append(k.get("also", a[4] if len(a) > 4 else None))
        return real(ref, *a, **k)

    monkeypatch.setattr(depth, "sweep_depths", counted)
    depth.run(depth.DepthConfig(neighbours=3), ws)
    assert len(calls) == 4 and all(c == (0.1, 1.0) for c in calls)
    calls.clear()
    real_views = depth.sweep_views

    def stop_after_first_pass(*a, **k):
        if k.get("label", "").endswith("novel frames"):
            raise KeyboardInterrupt
        return real_views(*a, **k)

    monkeypatch.setattr(depth, "sweep_views", stop_after_first_pass)
    with pytest.raises(KeyboardInterrupt):
        depth.run(depth.DepthConfig(neighbours=3), killed)
    monkeypatch.setattr(depth, "sweep_views", real_views)
    calls.clear()
    depth.run(depth.DepthConfig(neighbours=3), killed)
    assert calls == []  # both winners of every view were kept from the first run
    for s in sorted(p.stem for p in ws.images.glob("*.png")):
        for frames in (False, True):
            a, b = (read_depth(w, s, w.depth_path(s, frames)) for w in (ws, killed))
            assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True)), (s, frames)


def test_novel_agree_loosens_the_agreement_of_novel_frames_only():
    """``render --novel-agree``: four photos of a plane, two of them with noise of up to 0.15
    no gain removes: at the default tolerance fewer pixels have three agreeing photos than at
    0.3; the de-flared photos' fill (``novel`` off) keeps the default whatever the option
    says."""
    from dataclasses import replace

    from pipeline.render.config import RenderConfig
    from pipeline.render.fill import fill_from_photos
    from pipeline.render.jobs import FrameJob
    from pipeline.render.plan import resolve_fill

    rng = np.random.default_rng(3)
    centers = [[0.0, 0.0, -3.0], [0.12, 0.0, -3.0], [-0.12, 0.0, -3.0], [0.0, 0.12, -3.0],
               [0.0, -0.12, -3.0]]
    views, _ = plane_views(rng, centers)
    target, photos = views[0], views[1:]
    for v in photos:
        v.depth, _ = sweep_depth(v, [u for u in photos if u is not v], 2.0, 5.0,
                                 SweepConfig(planes=64))
    for v in photos[2:]:
        v.image = np.clip(v.image + rng.uniform(-0.15, 0.15, v.image.shape), 0, 1).astype(
            np.float32)  # noise no gain removes: the two disagree by more than 0.08
    stems = [f"v{i}" for i in range(1, 5)]
    by = dict(zip(stems, photos, strict=True))
    job = FrameJob(out=None, sources=stems, near=2.0, far=5.0, camera=None)
    base = RenderConfig(min_support=3)

    def weight(cfg, novel):
        return fill_from_photos(K, target.c2w, (W, H), job, by,
                                resolve_fill(cfg, "cpu", novel), novel=novel).weight.mean()

    tight, loose = (weight(replace(base, novel_agree=a, key_blend=0.0), True)
                    for a in (0.08, 0.3))
    assert loose > tight + 0.1, (tight, loose)
    assert weight(replace(base, novel_agree=0.3), False) == weight(base, False)


def test_twin_views_make_two_exact_crops_of_one_camera(tmp_path):
    """benchmarks/twin_views.py: every second view becomes two views from its camera (the left
    and right crops, principal point shifted), the others keep their middle crop; a world
    point projects onto the same photo pixel through each crop's camera."""
    from pipeline.cameras import load_cameras
    from pipeline.workspace import Workspace
    from pipeline.ws_files import read_view_image
    from tests.conftest import load_benchmark
    from tests.fixtures import make_plane_workspace

    ws = make_plane_workspace(tmp_path / "plane.ws", n_views=3, size=(160, 120))
    tv = load_benchmark("twin_views")
    stems = tv.make_twins(ws.root, tmp_path / "twin.ws", every=2, keep=0.75)
    assert stems == ["plane00a", "plane00b", "plane01", "plane02a", "plane02b"]
    new = Workspace(tmp_path / "twin.ws")
    new.require("pose")
    cams = load_cameras(new.cameras_json).by_stem()
    orig = load_cameras(ws.cameras_json).by_stem()
    img = read_view_image(ws, "plane00")
    X = np.array([0.1, -0.05, 0.0, 1.0])
    for s, x0 in (("plane00a", 0), ("plane00b", 40)):
        f = cams[s]
        assert (f.width, f.height) == (120, 120)
        assert np.allclose(f.c2w, orig["plane00"].c2w)
        u, v, w = f.K @ (np.linalg.inv(f.c2w) @ X)[:3]
        crop = read_view_image(new, s)
        assert crop.shape == (120, 120, 3)
        assert np.array_equal(crop, img[:, x0:x0 + 120])
        u0, v0, w0 = orig["plane00"].K @ (np.linalg.inv(f.c2w) @ X)[:3]
        assert np.isclose(u / w + x0, u0 / w0) and np.isclose(v / w, v0 / w0)
    assert np.array_equal(read_view_image(new, "plane01"),
                          read_view_image(ws, "plane01")[:, 20:140])
    with pytest.raises(Exception, match="exists"):
        tv.make_twins(ws.root, tmp_path / "twin.ws")
    # --turn: the two views look apart; each crop is the photo seen through its own camera
    # (the homography from the cameras, K_t R_t^T R K^-1, maps the photo onto the crop)
    import cv2

    from gnfr.paths import rotation_angle

    tv.make_twins(ws.root, tmp_path / "turn.ws", every=2, turn=10)
    turned = Workspace(tmp_path / "turn.ws")
    tc = load_cameras(turned.cameras_json).by_stem()
    o = orig["plane00"]
    for s in ("plane00a", "plane00b"):
        f = tc[s]
        Rt = np.asarray(f.c2w)[:3, :3].T @ np.asarray(o.c2w)[:3, :3]
        assert np.allclose(f.c2w[:3, 3], o.c2w[:3, 3])
        assert np.isclose(np.degrees(rotation_angle(np.asarray(o.c2w)[:3, :3],
                                                    np.asarray(f.c2w)[:3, :3])), 5.0)
        H = np.asarray(f.K) @ Rt @ np.linalg.inv(np.asarray(o.K))
        want = cv2.warpPerspective(img, H, (f.width, f.height), flags=cv2.INTER_LINEAR)
        got = read_view_image(turned, s)
        assert got.shape == want.shape and f.width < 160
        assert np.abs(got.astype(int) - want.astype(int))[2:-2, 2:-2].mean() < 1.0
    a, b = (np.asarray(tc[s].c2w)[:3, :3] for s in ("plane00a", "plane00b"))
    assert np.isclose(np.degrees(rotation_angle(a, b)), 10.0)
    # --middle: the twin's photo as it is comes first, unturned, cropped like the others, so
    # that `synth --heldout-every 4` holds out exactly the middles
    stems = tv.make_twins(ws.root, tmp_path / "mid.ws", every=2, turn=10, middle=True)
    assert stems == ["plane00m", "plane00a", "plane00b", "plane01", "plane02m", "plane02a",
                     "plane02b"]
    mid = Workspace(tmp_path / "mid.ws")
    mc = load_cameras(mid.cameras_json).by_stem()
    assert np.allclose(mc["plane00m"].c2w, o.c2w)
    w, h = mc["plane00m"].width, mc["plane00m"].height
    assert (w, h) == (tc["plane00a"].width, tc["plane00a"].height)
    x0, y0 = 80 - w // 2, 60 - h // 2
    assert np.array_equal(read_view_image(mid, "plane00m"), img[y0:y0 + h, x0:x0 + w])
    from pipeline.synth import heldout_indices
    assert [stems[i] for i in heldout_indices(len(stems), None, 4)] == ["plane00m",
                                                                       "plane02m"]
    with pytest.raises(Exception, match="--middle needs --turn"):
        tv.make_twins(ws.root, tmp_path / "mid2.ws", every=2, middle=True)
    # --spacing: the twins stand 0 apart and move no point; the arc's views do
    arc, twin = tv.spacing(ws.root), tv.spacing(new.root)
    assert arc["views"] == 3 and arc["views_with_a_neighbour_under_0.03"] == 0
    assert arc["nearest_parallax_px"][0] > 0.03 * 160
    assert twin["views"] == 5 and twin["views_with_a_neighbour_under_0.03"] == 4
    assert twin["nearest_distance"][0] == 0 and twin["nearest_parallax_px"][0] == 0
