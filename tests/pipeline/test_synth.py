"""The synth stage: 3D-consistent synthetic flare on a posed clean scene."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from pipeline import flare as F
from pipeline.cameras import Cameras, Frame, load_cameras
from pipeline.errors import UserError
from pipeline.synth import SynthConfig, choose_light, heldout_indices, project, run
from tests.fixtures import make_temple_workspace
from workflows.cli import main

SMALL = F.FlareConfig(psf_size=128, n_psfs=2, n_wavelengths=9, dust_count=(5, 20))


@pytest.fixture(scope="module")
def temple(tmp_path_factory):
    return make_temple_workspace(tmp_path_factory.mktemp("temple") / "ws", n_views=6, scale=0.5)


@pytest.fixture(autouse=True)
def _cache(tmp_path_factory, monkeypatch):
    monkeypatch.setenv("DEFLARE_CACHE", str(tmp_path_factory.getbasetemp() / "psf_cache"))


def _core_centroid(clean: np.ndarray, original: np.ndarray) -> np.ndarray | None:
    """[2] centroid (x, y) of the pixels the light's core brightened, or None."""
    diff = clean.astype(np.float32).sum(-1) - original.astype(np.float32).sum(-1)
    if (diff > 3).sum() < 3:
        return None
    yy, xx = np.nonzero(diff > 3)
    return np.array([xx.mean(), yy.mean()])


def test_synth_outputs_split_and_projected_light(temple, tmp_path):
    out = tmp_path / "flared"
    cfg = SynthConfig(out=out, seed=3, heldout=2, flare=SMALL)
    run(cfg, temple)
    cams = load_cameras(temple.cameras_json)
    split = json.loads((out / "split.json").read_text())
    assert len(split["heldout"]) == 2 and len(split["train"]) == 4
    assert sorted(split["train"] + split["heldout"]) == sorted(cams.stems)
    assert split["origin"] == temple.scene_name == "temple"
    assert sorted(p.stem for p in (out / "photos").glob("*.png")) == sorted(split["train"])
    assert load_cameras(out / "cameras_gt.json").stems == cams.stems
    assert (out / "README.md").is_file() and split["seed"] == 3
    light = np.array(split["light_world"])
    n_checked = 0
    for f in cams.frames:
        original = cv2.imread(str(temple.images / f"{f.stem}.png"))
        clean = cv2.imread(str(out / "clean" / f"{f.stem}.png"))
        mask = cv2.imread(str(out / "masks_gt" / f"{f.stem}.png"), cv2.IMREAD_GRAYSCALE)
        assert clean.shape == original.shape and mask.shape == original.shape[:2]
        assert set(np.unique(mask)) <= {0, 255}
        if f.stem in split["train"]:
            photo = cv2.imread(str(out / "photos" / f"{f.stem}.png"))
            assert photo.shape == original.shape
        xy = project(f, light)
        inside = xy is not None and 3 < xy[0] < f.width - 3 and 3 < xy[1] < f.height - 3
        c = _core_centroid(clean, original)
        if inside:  # the core lands where light_world projects
            assert c is not None and np.hypot(*(c - xy)) < 1.0
            assert mask[int(xy[1]), int(xy[0])] == 0  # the light itself is not flare
            n_checked += 1
        elif xy is None or min(xy[0], xy[1]) < -20 or xy[0] > f.width + 20 or xy[1] > \
                f.height + 20:
            assert c is None
    assert n_checked >= 3  # the chosen light is visible in most views
    assert split["views"][split["train"][0]]["flare"]


def test_synth_flare_is_where_light_projects_and_rerun_skips(temple, tmp_path):
    out = tmp_path / "flared"
    cams = load_cameras(temple.cameras_json)
    f = cams.frames[1]
    # a light 1 unit in front of view 1's camera, on its optical axis
    light = f.c2w[:3, 3] + f.c2w[:3, 2] * 1.0
    run(SynthConfig(out=out, seed=0, light=tuple(light), heldout_every=0, flare=SMALL), temple)
    xy = project(f, light)
    np.testing.assert_allclose(xy, f.K[:2, 2], atol=1e-6)
    photo = cv2.imread(str(out / "photos" / f"{f.stem}.png")).astype(np.float32)
    original = cv2.imread(str(temple.images / f"{f.stem}.png")).astype(np.float32)
    gain = (photo - original).sum(-1)
    yy, xx = np.mgrid[0:f.height, 0:f.width]
    near = np.hypot(xx - xy[0], yy - xy[1]) < 0.1 * np.hypot(f.width, f.height)
    assert gain[near].mean() > 5 * max(gain[~near].mean(), 1.0)  # flare centred on the light
    assert np.all(gain > -1)  # flare only adds light
    before = (out / "split.json").stat().st_mtime_ns
    run(SynthConfig(out=out, seed=0, light=tuple(light), heldout_every=0, flare=SMALL), temple)
    assert (out / "split.json").stat().st_mtime_ns == before  # up to date: skipped


def test_choose_light_visible_in_most_views(temple):
    cams = load_cameras(temple.cameras_json)
    light = choose_light(cams, np.random.default_rng(0))
    seen = [project(f, light) for f in cams.frames]
    inside = [xy is not None and 0 <= xy[0] < f.width and 0 <= xy[1] < f.height
              for xy, f in zip(seen, cams.frames, strict=True)]
    assert sum(inside) >= len(cams.frames) // 2
    again = choose_light(cams, np.random.default_rng(0))
    np.testing.assert_array_equal(light, again)


def test_choose_light_forward_facing_rig():
    """Nearly parallel cameras (LLFF-like): the light goes ahead of them, inside the frames."""
    rng = np.random.default_rng(0)
    K = np.array([[200.0, 0, 160], [0, 200.0, 120], [0, 0, 1]])
    frames = []
    for i in range(8):
        c2w = np.eye(4)
        c2w[:3, 3] = [rng.uniform(-0.3, 0.3), rng.uniform(-0.2, 0.2), 0.0]
        frames.append(Frame(name=f"{i}.png", stem=str(i), K=K, width=320, height=240,
                            c2w=c2w, near=0.5, far=4.0))
    light = choose_light(Cameras(frames=frames), rng)
    assert 0.5 < light[2] < 4.0
    inside = [(xy := project(f, light)) is not None and 0 <= xy[0] < 320 and 0 <= xy[1] < 240
              for f in frames]
    assert all(inside)


def test_heldout_indices():
    assert heldout_indices(10, None, 8) == [0, 8]
    assert heldout_indices(10, None, 0) == []
    assert heldout_indices(10, 3, 8) == [2, 4, 7]
    with pytest.raises(UserError):
        heldout_indices(4, 3, 8)
    with pytest.raises(UserError):
        heldout_indices(3, None, 1)


def test_synth_cli_and_bad_inputs(temple, tmp_path, capsys):
    (tmp_path / "nope").mkdir()
    assert main(["synth", str(tmp_path / "nope"), "--out", str(tmp_path / "o")]) == 2
    assert "not a deflare-scene workspace" in capsys.readouterr().err
    photos = temple.photos_dir
    inside = photos / "flared_out"
    assert main(["synth", str(temple.root), "--out", str(inside)]) == 2
    assert "inside the photo folder" in capsys.readouterr().err
    assert not inside.exists()
    assert main(["synth", str(temple.root), "--out", str(temple.root / "x")]) == 2
    assert main(["synth", str(temple.root), "--out", str(tmp_path / "o"), "--light",
                 "1,2"]) == 2
    assert "--light" in capsys.readouterr().err
    with pytest.raises(UserError):
        run(SynthConfig(out=tmp_path / "o", flare_prob=1.5, flare=SMALL), temple)
    out = tmp_path / "cli"
    code = main(["synth", str(temple.root), "--out", str(out), "--seed", "1",
                 "--heldout-every", "3", "--flare-prob", "0.5"])
    assert code == 0
    split = json.loads((out / "split.json").read_text())
    assert len(split["heldout"]) == 2  # views 0 and 3 of 6
    for stem in split["heldout"]:
        assert not (out / "photos" / f"{stem}.png").exists()
        assert (out / "clean" / f"{stem}.png").exists()
    for stem, v in split["views"].items():
        if not v["flare"]:  # no flare: no mask
            mask = cv2.imread(str(out / "masks_gt" / f"{stem}.png"), cv2.IMREAD_GRAYSCALE)
            assert not mask.any()


def test_synth_kinds_option(temple, tmp_path, capsys):
    bad = tmp_path / "bad"
    assert main(["synth", str(temple.root), "--out", str(bad), "--kinds", "starburst,sun"]) == 2
    err = capsys.readouterr().err.strip()
    assert "--kinds 'starburst,sun': unknown flare kind 'sun'; allowed kinds: starburst, " \
        "ghosts, streaks, glare, scatter" in err and len(err.splitlines()) == 1
    assert not bad.exists()
    out = tmp_path / "kinds"
    assert main(["synth", str(temple.root), "--out", str(out), "--kinds", "ghosts,glare",
                 "--heldout-every", "0"]) == 0
    split = json.loads((out / "split.json").read_text())
    assert split["kinds"] == ["ghosts", "glare"]
    assert split["lens"]["kinds"] and set(split["lens"]["kinds"]) <= {"ghosts", "glare"}
    assert set(split["lens"]["kind_params"]) == set(split["lens"]["kinds"])
    assert "--kinds ghosts,glare" in (out / "README.md").read_text()
