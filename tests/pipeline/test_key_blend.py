"""The novel frames' lean to the nearest photo (``render --key-blend``): at a photo's own
camera the frame is that photo outside its flare mask, however wrong the fill's depth and
however the other photos' fused colour differs; the lean fades with distance."""

import numpy as np

from pipeline.photo_fill import PhotoFill, lean_to_nearest, nearest_seen
from pipeline.render.fill import key_share
from pipeline.stereo import PosedView, warp_sources


def _view(x: float, seed: int, valid=None, depth=None) -> PosedView:
    rng = np.random.default_rng(seed)
    K = np.array([[40.0, 0, 24], [0, 40.0, 16], [0, 0, 1]])
    c2w = np.eye(4)
    c2w[0, 3] = x
    return PosedView(rng.random((32, 48, 3)).astype(np.float32), K, c2w, valid, depth)


def test_key_share_is_one_at_the_photo_and_fades_to_none():
    views = [_view(0.0, 0), _view(1.0, 1), _view(3.0, 2)]
    assert key_share(np.zeros(3), views, 0.5) == 1.0
    assert abs(key_share(np.array([0.25, 0, 0]), views, 0.5) - 0.5) < 1e-9
    assert key_share(np.array([0.5, 0, 0]), views, 0.5) == 0.0
    assert key_share(np.zeros(3), views, 0.0) == 0.0 and key_share(np.zeros(3), views[:1], 0.5) == 0


def test_key_power_keeps_the_lean_longer_and_still_ends_at_the_reach():
    """``render --key-power P``: the share is ``1 - x ** P`` at the fraction ``x`` of the way
    to the reach: 1 at the photo, none at the reach for any P, above the linear share between
    for P > 1."""
    views = [_view(0.0, 0), _view(1.0, 1)]
    for power in (1.0, 2.0, 3.0):
        assert key_share(np.zeros(3), views, 0.5, power) == 1.0
        assert key_share(np.array([0.5, 0, 0]), views, 0.5, power) == 0.0
        assert key_share(np.array([0.7, 0, 0]), views, 0.5, power) == 0.0
    at = np.array([0.25, 0, 0])  # half way to the reach
    assert key_share(at, views, 0.5, 2.0) == 0.75 and key_share(at, views, 0.5, 3.0) == 0.875
    assert key_share(at, views, 0.5) == 0.5


def test_at_the_photos_camera_the_frame_is_the_photo_outside_its_mask():
    mask = np.ones((32, 48), bool)
    mask[10:20, 10:30] = False  # flare: never taken from the photo
    wrong_depth = np.full((32, 48), 2.0, np.float32)  # the photo's own map disagrees
    photo = _view(0.0, 0, valid=mask, depth=np.full((32, 48), 5.0, np.float32))
    warped = warp_sources(photo.K, photo.c2w, wrong_depth, [photo])
    assert not warped.ok.any()  # the fill's own warp finds it all occluded
    fill = PhotoFill(colour=np.full((32, 48, 3), 0.5, np.float32),
                     support=np.zeros((32, 48), int), depth=wrong_depth, warped=warped)
    seen = nearest_seen(fill)
    assert seen.ok[0][mask].all() and not seen.ok[0][~mask].any()  # no occlusion test
    net_weight = np.zeros((32, 48), np.float32)  # the fill left every pixel to GN-FR
    colour, weight = lean_to_nearest(fill.colour, net_weight, seen, 1.0)
    far_from_flare = np.ones_like(mask)  # clear of the mask's eroded, feathered edge
    far_from_flare[10 - 5:20 + 5, 10 - 5:30 + 5] = False
    assert np.allclose(colour[far_from_flare], photo.image[far_from_flare], atol=1e-4)
    assert np.allclose(weight[far_from_flare], 1.0)
    assert (weight[~mask] == 0).all()  # inside the flare mask GN-FR stays
    half_colour, half_weight = lean_to_nearest(fill.colour, net_weight, seen, 0.5)
    assert np.allclose(half_weight[far_from_flare], 0.5)


def test_with_the_occlusion_test_the_lean_keeps_to_what_the_test_passes():
    """``render --key-occlusion``: the photo's pixels its own depth map hides are not leaned
    to; where the map agrees with the fill's depth they are."""
    depth = np.full((32, 48), 2.0, np.float32)
    own = depth.copy()
    own[:, 24:] = 5.0  # the photo's map disagrees on the right half: occluded there
    photo = _view(0.0, 0, valid=np.ones((32, 48), bool), depth=own)
    warped = warp_sources(photo.K, photo.c2w, depth, [photo])
    fill = PhotoFill(colour=np.full((32, 48, 3), 0.5, np.float32),
                     support=np.zeros((32, 48), int), depth=depth, warped=warped)
    assert nearest_seen(fill).ok[0].all()  # the default: no occlusion test
    tested = nearest_seen(fill, occluded=True).ok[0]
    assert tested[:, :23].all() and not tested[:, 25:].any()
    colour, weight = lean_to_nearest(fill.colour, np.zeros((32, 48), np.float32),
                                     nearest_seen(fill, occluded=True), 1.0)
    assert np.allclose(colour[4:-4, 4:18], photo.image[4:-4, 4:18], atol=1e-4)
    assert (weight[:, 25:] == 0).all()


def test_key_spot_reaches_past_a_twin_and_leans_to_it_where_the_nearest_does_not_see():
    """``render --key-spot``: a twin standing within the spot no longer ends the reach (the
    next spot's distance does), and the lean takes the twin where the nearest photo does
    not see the frame (its flare, or out of its view), the nearest first where both do."""
    from pipeline.render.fill import at_spot

    views = [_view(0.0, 0), _view(0.02, 1), _view(1.0, 2)]
    at = np.array([0.01, 0, 0])
    assert key_share(at, views, 0.5) == 0.0  # the twin, 0.02 away, ends the reach at 0.01
    assert abs(key_share(at, views, 0.5, same_spot=0.05) - (1 - 0.01 / 0.5)) < 1e-9
    assert at_spot(views, 0.05) == [0, 1] and at_spot(views, 0.0) == [0]
    assert at_spot(views, 0.01) == [0]
    # the composite: the nearest where it sees, the twin on its right half where it does not
    depth = np.full((32, 48), 2.0, np.float32)
    left = np.zeros((32, 48), bool)
    left[:, :24] = True
    near = _view(0.0, 0, valid=left)
    twin = _view(0.0, 1, valid=np.ones((32, 48), bool))  # same spot, sees all of it
    warped = warp_sources(near.K, near.c2w, depth, [near, twin])
    fill = PhotoFill(colour=np.full((32, 48, 3), 0.5, np.float32),
                     support=np.zeros((32, 48), int), depth=depth, warped=warped)
    one = nearest_seen(fill)
    assert one.ok[0][:, :23].all() and not one.ok[0][:, 25:].any()
    both = nearest_seen(fill, spot=[0, 1])
    assert both.ok[0].all() and both.colours.shape == (1, 32, 48, 3)
    assert np.allclose(both.colours[0][:, :23], near.image[:, :23], atol=1e-4)
    assert np.allclose(both.colours[0][:, 25:], twin.image[:, 25:], atol=1e-4)
    assert np.array_equal(nearest_seen(fill, spot=[0]).colours, one.colours)
