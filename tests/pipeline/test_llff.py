"""LLFF scenes (``pipeline.training_scenes.load_llff``): factor folders, axis order, bounds."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
import torch

from gnfr.geometry import project
from pipeline.errors import UserError
from pipeline.training_scenes import load_llff
from tests.conftest import shared

H0, W0, F0 = 240, 320, 300.0
"""Full-size camera of the synthetic scene (the poses' hwf); images_4 holds 80x60."""


def _look_at(centre: np.ndarray, target: np.ndarray) -> np.ndarray:
    """OpenCV c2w [4, 4] (x right, y down, z forward) at ``centre`` facing ``target``."""
    z = (target - centre) / np.linalg.norm(target - centre)
    x = np.cross([0.0, 1.0, 0.0], z)
    x /= np.linalg.norm(x)
    c2w = np.eye(4)
    c2w[:3, :3] = np.stack([x, np.cross(z, x), z], 1)
    c2w[:3, 3] = centre
    return c2w


def _synthetic_llff(folder, factor: int = 4):
    """An LLFF folder of 4 cameras around known points; returns (c2w [4, 4, 4], points
    [P, 3], full-size pixels [4, P, 2]). poses_bounds.npy is written from LLFF's definition:
    camera-to-world columns down, right, back, then the centre and [H, W, f]."""
    rng = np.random.default_rng(0)
    pts = rng.uniform(-1, 1, (40, 3))
    centres = np.array([[-0.6, -0.2, -4.0], [0.5, -0.3, -4.2], [0.1, 0.4, -3.8],
                        [0.7, 0.5, -4.1]])
    c2w = np.stack([_look_at(c, rng.uniform(-0.2, 0.2, 3)) for c in centres])
    K = np.array([[F0, 0, W0 / 2], [0, F0, H0 / 2], [0, 0, 1]])
    rows, pix = [], []
    for m in c2w:
        cam = (pts - m[:3, 3]) @ m[:3, :3]            # [P, 3] camera coordinates
        uv = cam @ K.T
        pix.append(uv[:, :2] / uv[:, 2:])
        R = m[:3, :3]
        llff = np.stack([R[:, 1], R[:, 0], -R[:, 2], m[:3, 3], [H0, W0, F0]], 1)
        bounds = [cam[:, 2].min(), cam[:, 2].max()]
        rows.append(np.concatenate([llff.reshape(-1), bounds]))
    np.save(folder / "poses_bounds.npy", np.array(rows))
    img_dir = folder / f"images_{factor}"
    img_dir.mkdir()
    for i in range(len(c2w)):
        img = rng.integers(0, 255, (H0 // factor, W0 // factor, 3), dtype=np.uint8)
        cv2.imwrite(str(img_dir / f"view{i}.png"), img)
    return c2w, pts, np.stack(pix)


def test_factor_folder_scales_K_and_poses_reproject_known_points(tmp_path):
    c2w, pts, pix = _synthetic_llff(tmp_path)
    sc = load_llff(tmp_path)
    assert sc.images.shape == (4, 3, H0 // 4, W0 // 4)
    K4 = torch.tensor([[F0 / 4, 0, W0 / 8], [0, F0 / 4, H0 / 8], [0, 0, 1]], dtype=torch.float64)
    assert torch.allclose(sc.K, K4.expand(4, 3, 3))
    # the loader moved the centres into the unit sphere by a similarity: recover it
    c0, c1 = c2w[:, :3, 3], sc.c2w[:, :3, 3].numpy()
    centre = c0.mean(0)
    s = np.linalg.norm(c1[0] - c1[1]) / np.linalg.norm(c0[0] - c0[1])
    assert np.allclose(c1, (c0 - centre) * s, atol=1e-9)
    assert np.allclose(sc.c2w[:, :3, :3].numpy(), c2w[:, :3, :3], atol=1e-9)
    # the same similarity applied to the points: they land where they were projected / 4
    xy, depth = project(torch.from_numpy((pts - centre) * s), sc.K, torch.linalg.inv(sc.c2w))
    assert torch.allclose(xy, torch.from_numpy(pix / 4), atol=1e-6)
    # bounds (min / max point depth) became near / far around every point, in scene units
    assert bool((depth > sc.near[:, None]).all()) and bool((depth < sc.far[:, None]).all())


def test_factor_folder_choice_skips_non_images_and_other_folders(tmp_path):
    _synthetic_llff(tmp_path)
    (tmp_path / "images_4" / ".DS_Store").write_bytes(b"\0\1")
    (tmp_path / "images_old").mkdir()                        # not a factor folder
    (tmp_path / "images").mkdir()                            # full size, blank
    for i in range(4):
        cv2.imwrite(str(tmp_path / "images" / f"view{i}.png"), np.zeros((H0, W0, 3), np.uint8))
    small = load_llff(tmp_path, max_size=W0 // 4)            # images_4 is large enough
    assert small.images.shape[-2:] == (H0 // 4, W0 // 4) and int(small.images.max()) > 0
    full = load_llff(tmp_path, max_size=W0)                  # only images/ is
    assert full.images.shape[-2:] == (H0, W0) and int(full.images.max()) == 0
    assert torch.allclose(full.K * torch.tensor([[0.25], [0.25], [1.0]], dtype=torch.float64),
                          small.K)


def test_images_of_another_aspect_than_the_poses_are_refused(tmp_path):
    _synthetic_llff(tmp_path)
    for p in (tmp_path / "images_4").glob("*.png"):           # portrait instead of landscape
        cv2.imwrite(str(p), np.zeros((W0 // 4, H0 // 4, 3), np.uint8))
    with pytest.raises(UserError, match="aspect"):
        load_llff(tmp_path)


# --------------------------------------------------------------------------- real: fern
@pytest.fixture(scope="module")
def fern():
    return load_llff(shared("scenes", "fern"))


def _sift(img: np.ndarray):
    cv2.setNumThreads(1)
    return cv2.SIFT_create(2000).detectAndCompute(cv2.cvtColor(img, cv2.COLOR_RGB2GRAY), None)


def _matches(fa, fb) -> dict[int, np.ndarray]:
    """Ratio-test matches: keypoint index in a -> pixel (x, y) in b, pixel centres at +0.5."""
    out = {}
    for m, n in cv2.BFMatcher(cv2.NORM_L2).knnMatch(fa[1], fb[1], k=2):
        if m.distance < 0.7 * n.distance:
            out[m.queryIdx] = np.array(fb[0][m.trainIdx].pt) + 0.5
    return out


def _third_view_error(sc, c2w: np.ndarray, a: int, b: int, c: int) -> tuple[int, float]:
    """Triangulate features matched in views a and b with the given cameras, reproject
    into view c: (number of points, median pixel error against c's matched features)."""
    imgs = sc.images.permute(0, 2, 3, 1).numpy()
    fa, fb, fc = (_sift(imgs[i]) for i in (a, b, c))
    mab, mac = _matches(fa, fb), _matches(fa, fc)
    common = [q for q in mab if q in mac]
    pa = np.array([np.array(fa[0][q].pt) + 0.5 for q in common])
    pb, pc = np.array([mab[q] for q in common]), np.array([mac[q] for q in common])
    K = sc.K.numpy()

    def P(i):
        return K[i] @ np.linalg.inv(c2w[i])[:3]
    X = cv2.triangulatePoints(P(a), P(b), pa.T, pb.T)
    x = P(c) @ X
    err = np.linalg.norm((x[:2] / x[2]).T - pc, axis=1)
    return len(common), float(np.median(err))


@pytest.mark.parametrize("views", [(0, 5, 10), (10, 15, 19)])
def test_fern_poses_triangulate_consistently(fern, views):
    assert fern.images.shape[-2:] == (378, 504)           # images_8 of 4032x3024
    assert float(fern.K[0, 0, 0]) == pytest.approx(3260.526 / 8, abs=0.01)
    c2w = fern.c2w.numpy()
    n, err = _third_view_error(fern, c2w, *views)
    assert n >= 15 and err < 1.5, (n, err)                 # measured: 0.46 and 0.23 px
    # the check has teeth: OpenGL axes (y up, z back) instead of OpenCV's miss by far more
    gl = c2w.copy()
    gl[:, :3, 1:3] *= -1
    assert _third_view_error(fern, gl, *views)[1] > 5 * max(err, 1.0)


def test_fern_near_far_from_bounds(fern):
    bounds = np.load(shared("scenes", "fern", "poses_bounds.npy"))[:, 15:17]
    near, far = fern.near.numpy(), fern.far.numpy()
    assert (near > 0).all() and (near < far).all()
    # one scale for the whole scene: ratios of the bounds survive (with the 0.9 / 1.1 margins)
    assert np.allclose(far / near, bounds[:, 1] * 1.1 / (bounds[:, 0] * 0.9))
    assert np.allclose(near / near[0], bounds[:, 0] / bounds[0, 0])


def test_scene_pack_round_trip_and_shrink(tmp_path):
    """A scene pack (the file that carries training scenes to a GPU machine) keeps cameras
    exactly, images within JPEG error, masks exactly; a smaller max_size shrinks K alike."""
    from pipeline.training_scenes import PACK_FILE, detect_and_load, save_pack
    from workflows.research.pretrain import find_scenes

    (tmp_path / "llff").mkdir()
    _synthetic_llff(tmp_path / "llff")
    sc = load_llff(tmp_path / "llff")
    # smooth images (JPEG is exact enough on them) and a mask that is not all one value
    yy, xx = np.mgrid[:sc.images.shape[2], :sc.images.shape[3]]
    smooth = np.stack([(xx * 3) % 256, (yy * 4) % 256, (xx + yy) % 256], 0).astype(np.uint8)
    sc.images[:] = torch.from_numpy(smooth)
    masks = torch.zeros(4, 1, *sc.images.shape[2:], dtype=torch.uint8)
    masks[1, 0, 5:20, 7:31] = 1
    sc.masks = masks
    save_pack(sc, tmp_path / "packs" / "llff")
    assert (tmp_path / "packs" / "llff" / PACK_FILE).is_file()
    assert find_scenes([tmp_path / "packs"]) == [tmp_path / "packs" / "llff"]
    back = detect_and_load(tmp_path / "packs" / "llff", max_size=504)
    assert back.stems == sc.stems and back.name == sc.name
    for a in ("K", "c2w", "near", "far"):
        assert torch.equal(getattr(back, a), getattr(sc, a)), a
    err = (back.images.float() - sc.images.float()).abs().mean()
    assert float(err) < 3.0, float(err)
    assert torch.equal(back.masks, masks)
    assert back.flare[sc.stems[1]] > 0 and back.flare[sc.stems[0]] == 0
    small = detect_and_load(tmp_path / "packs" / "llff", max_size=40)
    assert small.images.shape[-1] == 40 and small.images.shape[-2] == 30
    assert torch.allclose(small.K[:, :2], sc.K[:, :2] / 2)


def test_shrink_scene_scales_views_masks_and_K(tmp_path):
    from pipeline.training_scenes import shrink_scene

    _synthetic_llff(tmp_path)
    sc = load_llff(tmp_path)  # 80x60
    sc.masks = torch.zeros(4, 1, 60, 80, dtype=torch.uint8)
    sc.masks[2, 0, 10:30, 20:60] = 1
    small = shrink_scene(sc, 40)
    assert small.images.shape == (4, 3, 30, 40) and small.masks.shape == (4, 1, 30, 40)
    assert torch.allclose(small.K[:, :2], sc.K[:, :2] / 2)
    assert int(small.masks[2].sum()) == 200 and int(small.masks[[0, 1, 3]].sum()) == 0
    assert shrink_scene(sc, 504).images.shape == sc.images.shape  # never enlarged


def test_a_damaged_scene_pack_is_one_clear_error(tmp_path):
    from pipeline.errors import UserError
    from pipeline.training_scenes import PACK_FILE, detect_and_load

    (tmp_path / "s").mkdir()
    np.savez(tmp_path / "s" / PACK_FILE, stems=np.array(["a"]))  # fields missing
    with pytest.raises(UserError, match="not a readable scene pack.*scene_pack"):
        detect_and_load(tmp_path / "s")
