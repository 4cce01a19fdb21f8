"""The mask and select stages on a small kermit workspace (cameras placed on a circle)."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from gnfr.fmg import build_fmg, save_fmg, tiny_config
from gnfr.paths import look_at
from pipeline.cameras import Cameras, Frame, load_cameras, save_cameras
from pipeline.errors import UserError
from pipeline.workspace import Workspace, atomic_imwrite
from tests.conftest import fake_fmg_probs, shared
from workflows.cli import main


def make_kermit_ws(root: Path, n: int = 6, scale: float = 0.5) -> Workspace:
    """Kermit views in WS/images, cameras on a circle (angle = view order), pose 'done'."""
    src = shared("scenes", "kermit")
    names = sorted(p.name for p in src.iterdir() if p.suffix.lower() == ".jpg")[:n]
    ws = Workspace.create(root, src)
    frames = []
    for i, name in enumerate(names):
        img = cv2.imread(str(src / name))
        h, w = img.shape[:2]
        W, H = round(w * scale), round(h * scale)
        img = cv2.resize(img, (W, H), interpolation=cv2.INTER_AREA)
        stem = Path(name).stem
        atomic_imwrite(ws.images / f"{stem}.png", img)
        a = 2 * np.pi * i / (2 * n)
        K = np.array([[0.9 * W, 0, W / 2], [0, 0.9 * W, H / 2], [0, 0, 1.0]])
        frames.append(Frame(name=name, stem=stem, K=K, width=W, height=H,
                            c2w=look_at(np.array([np.cos(a), 0.0, np.sin(a)]), np.zeros(3),
                                        np.array([0.0, -1.0, 0.0])),
                            near=0.3, far=2.0,
                            colmap_camera={"model": "PINHOLE", "width": W, "height": H,
                                           "params": [K[0, 0], K[1, 1], K[0, 2], K[1, 2]]}))
    save_cameras(ws.cameras_json, Cameras(frames=frames))
    ws.record_stage("pose", {"fixture": "kermit-circle"}, [ws.images, ws.cameras_json])
    return ws


def box_mask(h: int, w: int, fraction: float) -> np.ndarray:
    """uint8 mask with a top-left box covering about ``fraction`` of the image."""
    m = np.zeros((h, w), np.uint8)
    side = np.sqrt(fraction * h * w / (w / h))
    bh, bw = round(side), round(side * w / h)
    m[:bh, :bw] = 255
    return m


@pytest.fixture
def kermit_ws(tmp_path):
    return make_kermit_ws(tmp_path / "ws")


@pytest.fixture
def tiny_weights(tmp_path):
    import torch

    torch.manual_seed(0)
    return save_fmg(tmp_path / "tiny.safetensors", build_fmg(tiny_config()))


def test_mask_cut_comes_from_the_weights_unless_given(kermit_ws, tiny_weights):
    from workflows.research.fmg_eval import write_threshold

    ws = kermit_ws
    write_threshold(tiny_weights, 0.65)
    assert main(["mask", str(ws.root), "--weights", str(tiny_weights)]) == 0
    assert json.loads(ws.flare_json.read_text())["threshold"] == 0.65
    assert main(["mask", str(ws.root), "--weights", str(tiny_weights), "--threshold", "0.3"]) == 0
    assert json.loads(ws.flare_json.read_text())["threshold"] == 0.3


def test_mask_stage_fmg_outputs(kermit_ws, tiny_weights):
    ws = kermit_ws
    assert main(["mask", str(ws.root), "--weights", str(tiny_weights)]) == 0
    flare = json.loads(ws.flare_json.read_text())
    stems = sorted(p.stem for p in ws.images.glob("*.png"))
    assert flare["source"] == "fmg" and flare["threshold"] == 0.5
    assert flare["weights"].startswith("tiny.safetensors@sha256:")
    assert sorted(flare["views"]) == stems
    for s in stems:
        img = cv2.imread(str(ws.images / f"{s}.png"))
        m = cv2.imread(str(ws.masks / f"{s}.png"), cv2.IMREAD_UNCHANGED)
        assert m.dtype == np.uint8 and m.shape == img.shape[:2]
        assert set(np.unique(m)) <= {0, 255}
        assert flare["views"][s]["flare_fraction"] == pytest.approx((m > 0).mean(), abs=1e-6)
    assert cv2.imread(str(ws.masks_overview)) is not None
    # unchanged inputs: skipped, masks untouched
    mtime = (ws.masks / f"{stems[0]}.png").stat().st_mtime_ns
    assert main(["mask", str(ws.root), "--weights", str(tiny_weights)]) == 0
    assert (ws.masks / f"{stems[0]}.png").stat().st_mtime_ns == mtime


def _rerun_with(ws, tiny_weights, *extra: str):
    """Mask the first view of ``ws`` at a cut that marks half of it, then again with the
    options ``extra``: (model, image, cut, its mask after the second run), the second run
    checked to have rewritten the mask (a change of those options is not skipped)."""
    from pipeline.mask import fmg_probs, load_fmg_weights

    stems, _ = _stems_and_size(ws)
    model = load_fmg_weights(tiny_weights)
    img = cv2.imread(str(ws.images / f"{stems[0]}.png"))
    cut = float(np.median(fmg_probs(model, [img], 512)[0]))  # a cut that marks half
    args = ["mask", str(ws.root), "--weights", str(tiny_weights), "--no-rays",
            "--threshold", repr(cut), "--pads", "none"]
    assert main(args) == 0
    before = (ws.masks / f"{stems[0]}.png").stat().st_mtime_ns
    assert main([*args, *extra]) == 0
    assert (ws.masks / f"{stems[0]}.png").stat().st_mtime_ns != before  # not skipped
    return model, img, cut, cv2.imread(str(ws.masks / f"{stems[0]}.png"),
                                       cv2.IMREAD_UNCHANGED) > 0


def test_mask_scales_average_the_networks_runs(kermit_ws, tiny_weights):
    """`mask --scales 1,0.75` writes the masks of the probabilities averaged over 512 and
    384 px (what `flare_marks` cuts), and a change of scales makes the stage run again."""
    from pipeline.mask import flare_marks

    model, img, cut, got = _rerun_with(kermit_ws, tiny_weights, "--scales", "1,0.75")
    want = flare_marks(model, img, cut, 512, scales=(1.0, 0.75))
    assert np.array_equal(got, want)
    assert not np.array_equal(want, flare_marks(model, img, cut, 512))  # scales matter


def test_mask_pads_write_the_lowest_of_the_padded_runs(kermit_ws, tiny_weights, capsys):
    """`mask --pads reflect,constant --pads-keep pixels` writes the masks of the lowest
    probability over the plain and padded runs, runs the stage again when the pads change,
    and an unknown padding is one line naming the option, exit 2."""
    from pipeline.mask import flare_marks

    ws = kermit_ws
    model, img, cut, got = _rerun_with(ws, tiny_weights, "--pads", "reflect,constant",
                                       "--pads-keep", "pixels")
    want = flare_marks(model, img, cut, 512, pads=("reflect", "constant"))
    assert np.array_equal(got, want)
    args = ["mask", str(ws.root), "--weights", str(tiny_weights), "--no-rays",
            "--threshold", repr(cut)]
    plain = flare_marks(model, img, cut, 512)
    assert want.sum() < plain.sum() and not (want & ~plain).any()  # only marks removed
    capsys.readouterr()
    assert main([*args, "--pads", "wrap"]) == 2
    err = capsys.readouterr().err
    assert "--pads" in err and "wrap" in err and "Traceback" not in err


def test_mask_pads_keep_regions_keeps_the_plain_regions_the_pads_agree_on(kermit_ws,
                                                                          tiny_weights, capsys):
    """`mask --pads constant --pads-keep regions`: the plain pass's marked regions that hold
    a pixel the padded runs agree on, whole (here with one padding); --pads-keep regions
    with --pads none is one line, exit 2."""
    from pipeline.mask import fmg_probs, load_fmg_weights, regions_touching

    ws = kermit_ws
    stems, _ = _stems_and_size(ws)
    model = load_fmg_weights(tiny_weights)
    img = cv2.imread(str(ws.images / f"{stems[0]}.png"))
    plain = fmg_probs(model, [img], 512)[0]
    agreed = fmg_probs(model, [img], 512, pads=("constant",))[0]
    cut = float(np.quantile(plain, 0.9))  # a cut that marks a tenth
    args = ["mask", str(ws.root), "--weights", str(tiny_weights), "--no-rays",
            "--no-ghost-lines", "--threshold", repr(cut), "--pads", "constant"]
    assert main([*args, "--pads-keep", "regions"]) == 0
    got = cv2.imread(str(ws.masks / f"{stems[0]}.png"), cv2.IMREAD_UNCHANGED) > 0
    assert np.array_equal(got, regions_touching(plain > cut, agreed > cut))
    assert ((agreed > cut) & ~got).sum() == 0 and (got & ~(plain > cut)).sum() == 0
    assert main([*args, "--pads-keep", "pixels"]) == 0  # a subset of the regions
    pixels = cv2.imread(str(ws.masks / f"{stems[0]}.png"), cv2.IMREAD_UNCHANGED) > 0
    assert not (pixels & ~got).any() and got.sum() >= pixels.sum()
    capsys.readouterr()
    assert main(["mask", str(ws.root), "--pads", "none", "--pads-keep", "regions"]) == 2
    err = capsys.readouterr().err
    assert "--pads-keep" in err and "--pads is none" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
    lone = regions_touching(np.array([[1, 1, 0, 1]], bool), np.array([[0, 1, 0, 0]], bool))
    assert lone.tolist() == [[True, True, False, False]]  # a region never agreed on goes

def _stems_and_size(ws) -> tuple[list[str], tuple[int, int]]:
    """The workspace's stems and the (H, W) of its images."""
    stems = sorted(p.stem for p in ws.images.glob("*.png"))
    return stems, cv2.imread(str(ws.images / f"{stems[0]}.png")).shape[:2]


def _write_given(tmp_path, masks: dict):
    """Hand-made masks as tmp_path/given/<stem>.png; returns the folder."""
    given = tmp_path / "given"
    given.mkdir()
    for s, m in masks.items():
        cv2.imwrite(str(given / f"{s}.png"), m)
    return given


def test_given_masks_and_ten_percent_rule(kermit_ws, tmp_path):
    ws = kermit_ws
    stems, (h, w) = _stems_and_size(ws)
    fracs = {s: (0.15 if i % 3 == 0 else 0.05) for i, s in enumerate(stems)}
    # written at half size with values 0/1: must be resized to image size, nonzero = flare
    given = _write_given(tmp_path, {s: (box_mask(h // 2, w // 2, f) > 0).astype(np.uint8)
                                    for s, f in fracs.items()})
    assert main(["mask", str(ws.root), "--masks", str(given)]) == 0
    flare = json.loads(ws.flare_json.read_text())
    assert flare["source"].startswith("masks:")
    for s in stems:
        m = cv2.imread(str(ws.masks / f"{s}.png"), cv2.IMREAD_UNCHANGED)
        assert m.shape == (h, w) and m.max() == 255
        assert flare["views"][s]["flare_fraction"] == pytest.approx(fracs[s], abs=0.01)
    assert main(["select", str(ws.root)]) == 0
    views = json.loads(ws.views_json.read_text())
    assert views["max_flare"] == 0.1
    cams = load_cameras(ws.cameras_json).by_stem()
    for s in stems:
        v = views["views"][s]
        assert v["target"] == (fracs[s] < 0.1)
        src = v["sources"]
        assert sorted(x["stem"] for x in src) == sorted(set(stems) - {s})
        d = [x["distance"] for x in src]
        assert d == sorted(d)
        for x in src:
            true_d = np.linalg.norm(cams[s].center - cams[x["stem"]].center)
            assert x["distance"] == pytest.approx(true_d, abs=1e-5)
            assert x["flare_fraction"] == flare["views"][x["stem"]]["flare_fraction"]
    # neighbours on the circle: the nearest source of view i is i-1 or i+1
    i = 2
    assert views["views"][stems[i]]["sources"][0]["stem"] in (stems[1], stems[3])


def test_select_refuses_when_too_flared(kermit_ws, tmp_path):
    ws = kermit_ws
    stems, (h, w) = _stems_and_size(ws)
    given = _write_given(tmp_path, {s: box_mask(h, w, 0.05 if i == 0 else 0.15)
                                    for i, s in enumerate(stems)})
    assert main(["mask", str(ws.root), "--masks", str(given)]) == 0
    from pipeline.select import SelectConfig, run

    with pytest.raises(UserError) as e:
        run(SelectConfig(), ws)
    msg = str(e.value)
    assert f"{stems[1]} (15." in msg and "--max-flare" in msg and "--masks" in msg
    assert stems[0] + " (" not in msg
    assert main(["select", str(ws.root), "--max-flare", "0.2"]) == 0


def test_given_masks_missing_stem_named(kermit_ws, tmp_path):
    ws = kermit_ws
    stems = sorted(p.stem for p in ws.images.glob("*.png"))
    given = tmp_path / "given"
    given.mkdir()
    for s in stems[1:]:
        cv2.imwrite(str(given / f"{s}.png"), np.zeros((8, 8), np.uint8))
    from pipeline.mask import MaskConfig, run

    with pytest.raises(UserError, match=f"no mask for view '{stems[0]}'"):
        run(MaskConfig(masks_dir=given), ws)


def test_missing_weights_is_clear_error(kermit_ws, tmp_path, capsys):
    code = main(["mask", str(kermit_ws.root), "--weights", str(tmp_path / "nope.safetensors")])
    assert code == 2
    err = capsys.readouterr().err
    assert "nope.safetensors" in err and "no such file" in err  # checked before any work
    assert "Traceback" not in err
    # the shipped file missing (a broken install) names how to make one
    from pipeline.errors import UserError
    from pipeline.mask import load_fmg_weights
    with pytest.raises(UserError, match="deflare-scene fmg train"):
        load_fmg_weights(tmp_path / "nope.safetensors")


def test_foreign_weights_is_clear_error(kermit_ws, tmp_path, capsys):
    bad = tmp_path / "bad.safetensors"
    bad.write_bytes(b"not a safetensors file")
    before = {p: p.read_bytes() if p.is_file() else None for p in kermit_ws.root.rglob("*")}
    assert main(["mask", str(kermit_ws.root), "--weights", str(bad)]) == 2
    assert "cannot be used" in capsys.readouterr().err
    # failed before touching the workspace: no masks folder, manifest unchanged
    after = {p: p.read_bytes() if p.is_file() else None for p in kermit_ws.root.rglob("*")}
    assert after == before


def test_shipped_fmg_on_synthesized_kermit(tmp_path):
    """The shipped weights on held-out kermit views with synthetic flare, and one clean view."""
    from gnfr.fmg import confusion, seg_metrics
    from pipeline import flare as fl
    from pipeline.mask import DEFAULT_WEIGHTS

    assert DEFAULT_WEIGHTS.is_file(), "the shipped FMG weights are part of the package"
    ws = make_kermit_ws(tmp_path / "ws", n=4)
    stems = sorted(p.stem for p in ws.images.glob("*.png"))
    rng = np.random.default_rng(7)
    gt = {}
    for s in stems[1:]:
        img = cv2.imread(str(ws.images / f"{s}.png"))[..., ::-1]
        h, w = img.shape[:2]
        light = (float(rng.uniform(0.2, 0.8) * w), float(rng.uniform(0.2, 0.8) * h))
        flared, layers = fl.synthesize(img, fl.FlareConfig(), rng, light)
        atomic_imwrite(ws.images / f"{s}.png",
                       (np.clip(flared, 0, 1)[..., ::-1] * 255 + 0.5).astype(np.uint8))
        gt[s] = layers.mask
    assert main(["mask", str(ws.root)]) == 0
    flare = json.loads(ws.flare_json.read_text())
    assert flare["weights"].startswith("fmg.safetensors@sha256:")
    conf = sum(confusion(torch_from(read_png_mask(ws, s)), torch_from(gt[s])) for s in gt)
    m = seg_metrics(conf)
    assert m["mIoU"] > 0.6, m
    clean = flare["views"][stems[0]]["flare_fraction"]
    assert clean < 0.05 and clean < min(flare["views"][s]["flare_fraction"] for s in gt)


def read_png_mask(ws: Workspace, stem: str) -> np.ndarray:
    return cv2.imread(str(ws.masks / f"{stem}.png"), cv2.IMREAD_GRAYSCALE) > 127


def torch_from(a: np.ndarray):
    import torch

    return torch.from_numpy(np.ascontiguousarray(a))


def test_refine_follows_image_edges():
    from pipeline.mask import refine_probs

    ideal = np.zeros((64, 64), np.float32)
    ideal[:, 32:] = 1.0
    image = np.repeat((ideal * 200 + 20).astype(np.uint8)[..., None], 3, axis=2)
    blurry = cv2.GaussianBlur(ideal, (0, 0), 4)
    refined = refine_probs(image, blurry)
    assert refined.shape == ideal.shape and refined.min() >= 0 and refined.max() <= 1
    # the probability now jumps where the image does (columns 31 -> 32), not gradually
    jump = refined[:, 32] - refined[:, 31]
    assert (jump > 3 * (blurry[:, 32] - blurry[:, 31])).all()
    assert (jump > 5 * np.abs(refined[:, 31] - refined[:, 30])).all()
    assert abs(refined.mean() - blurry.mean()) < 0.02


def test_mask_stage_refine_option(kermit_ws, tiny_weights):
    ws = kermit_ws
    assert main(["mask", str(ws.root), "--weights", str(tiny_weights), "--refine",
                 "--threshold", "0.4"]) == 0
    rec = ws.stage_record("mask")
    assert rec["params"]["refine"] is True and rec["params"]["threshold"] == 0.4
    assert rec["params"]["rays"] is True  # the default
    first = next(ws.masks.glob("*.png"))
    before = first.stat().st_mtime_ns
    assert main(["mask", str(ws.root), "--weights", str(tiny_weights), "--refine",
                 "--threshold", "0.4", "--no-rays"]) == 0  # a new option redoes the masks
    assert ws.stage_record("mask")["params"]["rays"] is False
    assert main(["mask", str(ws.root), "--weights", str(tiny_weights), "--refine",
                 "--threshold", "0.4", "--ray-min", "1", "--ray-opposite", "8"]) == 0
    params = ws.stage_record("mask")["params"]
    assert params["rays"] is True and params["ray_min"] == 1 and params["ray_opposite"] == 8
    assert first.stat().st_mtime_ns != before
    assert json.loads(ws.flare_json.read_text())["threshold"] == 0.4


def test_ray_config_of_the_mask_stage():
    from pipeline.flare_rays import RayConfig
    from pipeline.mask import MaskConfig, ray_config

    assert ray_config(MaskConfig()) == RayConfig()
    assert ray_config(MaskConfig(ray_min=1, ray_opposite=8.0)) == RayConfig(min_rays=1,
                                                                           opposite=8.0)


def _fmg_mask(ws: Workspace, stem: str, cfg) -> np.ndarray:
    """The mask the stage's FMG writer (``write_fmg_masks``, model None: the test's fake
    probabilities) writes for ``stem`` with ``cfg``."""
    from pipeline.mask import write_fmg_masks

    write_fmg_masks(None, cfg, ws, [stem])
    return cv2.imread(str(ws.mask_path(stem)), cv2.IMREAD_UNCHANGED) > 0


def test_fill_holes_marks_what_an_fmg_mask_encloses(kermit_ws, monkeypatch):
    """`mask --fill-holes`: the unmarked core a ring of flare encloses is marked too; the
    ring alone otherwise; nothing outside the ring changes either way."""
    from pipeline import mask as M

    ws = kermit_ws
    stems, (h, w) = _stems_and_size(ws)
    yy, xx = np.mgrid[:h, :w]
    r = np.hypot(yy - h / 2, xx - w / 2)
    ring = (r > 10) & (r < 25)

    def fake_probs(model, imgs, work_size, scales=(1.0,), pads=()):
        return [ring.astype(np.float32) for _ in imgs]

    fake_fmg_probs(monkeypatch, fake_probs)
    got = {fill: _fmg_mask(ws, stems[0], M.MaskConfig(threshold=0.5, rays=False,
                                                      fill_holes=fill))
           for fill in (False, True)}
    assert (got[False] == ring).all()
    assert (got[True] == (r < 25)).all()


def test_ghost_lines_in_the_mask_stage(kermit_ws, monkeypatch, tmp_path):
    """`mask --ghost-lines`: the stage adds the ghost-line regions of the network's own
    probabilities to its mask, records the option (a change redoes the masks), and refuses
    it beside --masks in one line."""
    from pipeline import mask as M

    ws = kermit_ws
    stems, (h, w) = _stems_and_size(ws)
    yy, xx = np.mgrid[:h, :w]
    strong = np.hypot(yy - h / 2, xx - w / 2) < 10
    weak = np.hypot(yy - 20, xx - 30) < 8
    probs = np.where(strong, 0.9, np.where(weak, 0.4, 0.0)).astype(np.float32)
    seen = []

    def fake_probs(model, imgs, work_size, scales=(1.0,), pads=()):
        return [probs for _ in imgs]

    def fake_ghosts(image_bgr, p, work_size, ghost_cfg=None, found=None):
        seen.append(ghost_cfg)
        return (p > ghost_cfg.low) & (p <= 0.5)  # stands in for the line rule: the weak disc

    fake_fmg_probs(monkeypatch, fake_probs)
    monkeypatch.setattr(M, "ghost_marks", fake_ghosts)
    got = {ghosts: _fmg_mask(ws, stems[0], M.MaskConfig(threshold=0.75, rays=False,
                                                        ghost_lines=ghosts))
           for ghosts in (False, True)}
    assert (got[False] == strong).all() and (got[True] == (strong | weak)).all()
    assert len(seen) == 1 and seen[0].low == 0.25  # the rule's defaults, only when asked
    monkeypatch.setattr(M, "load_fmg_weights", lambda path, device="cpu", flag="": None)
    M.run(M.MaskConfig(threshold=0.75, rays=False, ghost_lines=False), ws, force=True)
    assert ws.stage_record("mask")["params"]["ghost_lines"] is False
    assert ws.stage_record("mask")["params"]["ghost_views"] is False
    M.run(M.MaskConfig(threshold=0.75, rays=False, ghost_lines=True, ghost_views=False), ws)
    assert ws.stage_record("mask")["params"]["ghost_lines"] is True
    assert (read_png_mask(ws, stems[0]) == (strong | weak)).all()
    # the defaults since the thirty-fifth session: ghost lines the other photos judge
    assert M.check_config(M.MaskConfig()).ghost_lines is True
    with pytest.raises(UserError, match="--ghost-lines adds to an FMG's marks"):
        M.run(M.MaskConfig(ghost_lines=True, masks_dir=tmp_path), ws)
    with pytest.raises(UserError, match="--ghost-views lets the other photos judge"):
        M.check_config(M.MaskConfig(ghost_views=True, masks_dir=tmp_path))
    # the same rules through validate alone (the one-shot checks every stage so)
    from pipeline.options import validate

    with pytest.raises(UserError, match="--crosscheck checks an FMG's marks"):
        validate(M.MaskConfig(crosscheck=True, masks_dir=tmp_path))
    with pytest.raises(UserError, match="--ghost-chain sets the ghost lines' rule"):
        validate(M.MaskConfig(masks_dir=tmp_path, ghost_chain=2))
    # hand-made masks with the defaults: the ghost lines are off, no error
    assert M.check_config(M.MaskConfig(masks_dir=tmp_path)).ghost_lines is False
    with pytest.raises(UserError, match="--ghost-chain sets the ghost lines' rule"):
        M.run(M.MaskConfig(ghost_lines=False, ghost_chain=1), ws)
    assert M.ghost_config(M.MaskConfig(ghost_lines=True, ghost_chain=1)).min_chain == 1
    assert M.ghost_config(M.MaskConfig(ghost_lines=True)).min_chain == 2


def test_confirmed_regions_keep_what_both_masks_find():
    """A region of either mask is kept, whole, when the other mask marks one of its pixels;
    a region only one mask has is dropped; diagonal neighbours are one region."""
    from pipeline.mask import confirmed_regions

    a, b = np.zeros((12, 12), bool), np.zeros((12, 12), bool)
    a[1:4, 1:4] = True          # confirmed by b's square, which it overlaps at one pixel
    b[3:7, 3:7] = True
    a[7, 7] = a[8, 8] = True    # one region (8-connected), touching b's square diagonally only
    a[10, 0:3] = True           # a's alone: dropped
    b[0, 10:12] = True          # b's alone: dropped
    got = confirmed_regions(a, b)
    want = np.zeros_like(a)
    want[1:4, 1:4] = want[3:7, 3:7] = True
    assert (got == want).all()
    assert not confirmed_regions(a, np.zeros_like(b)).any()
    assert (confirmed_regions(a, a) == a).all()
    first = np.zeros_like(a)
    first[1:4, 1:4] = True      # keep "first": a's confirmed square only, none of b's
    assert (confirmed_regions(a, b, keep="first") == first).all()


def test_confirm_keeps_the_flare_both_networks_mark(kermit_ws, monkeypatch):
    """`mask --confirm`: a blob only the first network marks and a spot only the second marks
    are dropped; a flare both mark keeps the first's ring and the second's arm through it,
    and the core the ring encloses is marked; the stage records the second network."""
    from pipeline import mask as M

    ws = kermit_ws
    stems, (h, w) = _stems_and_size(ws)
    yy, xx = np.mgrid[:h, :w]
    r = np.hypot(yy - h / 2, xx - w / 2)
    ring = (r > 10) & (r < 25)
    arm = (np.abs(yy - h / 2) < 2) & (xx > w / 2) & (xx < w / 2 + 60)
    first = ring | (np.hypot(yy - 8, xx - 8) < 5)                # + a blob in a corner
    second = (ring & (xx > w / 2)) | arm | (np.hypot(yy - h + 8, xx - 8) < 4)

    def fake_probs(model, imgs, work_size, scales=(1.0,), pads=()):
        return [(first if model == "first" else second).astype(np.float32) for _ in imgs]

    fake_fmg_probs(monkeypatch, fake_probs)
    cfg = M.MaskConfig(threshold=0.5, rays=False, confirm=True)
    M.write_fmg_masks("first", cfg, ws, stems[:1], confirm=("second", 0.5, "both"))
    got = cv2.imread(str(ws.mask_path(stems[0])), cv2.IMREAD_UNCHANGED) > 0
    assert (got == ((r < 25) | arm)).all()
    cfg = M.MaskConfig(threshold=0.5, rays=False, confirm=True, confirm_keep="first")
    M.write_fmg_masks("first", cfg, ws, stems[:1], confirm=("second", 0.5, "first"))
    got = cv2.imread(str(ws.mask_path(stems[0])), cv2.IMREAD_UNCHANGED) > 0
    assert (got == ring).all()  # the first's confirmed ring alone: no arm, no core, no blob
    monkeypatch.setattr(M, "load_fmg_weights", lambda path, device="cpu", flag="": path.name)
    M.run(M.MaskConfig(rays=False, confirm=True), ws, force=True)
    params = ws.stage_record("mask")["params"]
    assert params["confirm"] is True and params["confirm_cut"] == pytest.approx(0.85)
    assert params["confirm_weights"].startswith("fmg_candidate_L.safetensors@sha256:")
    M.run(M.MaskConfig(rays=False), ws, force=True)
    params = ws.stage_record("mask")["params"]
    assert params["confirm"] is False and "confirm_cut" not in params
    man = json.loads(ws.manifest_path.read_text())     # as an earlier version recorded it
    for key in ("confirm", "confirm_weights", "confirm_keep"):
        del man["stages"]["mask"]["params"][key]
    ws.manifest_path.write_text(json.dumps(man))
    M.run(M.MaskConfig(rays=False), ws)
    assert "confirm" not in ws.stage_record("mask")["params"]  # up to date: not rewritten


def test_confirm_bad_inputs_fail_before_the_workspace_changes(kermit_ws, tmp_path):
    """`mask --confirm-weights` without `--confirm`, or a file that is no FMG, is one clear
    UserError naming the option, and the masks of the earlier run stay."""
    from pipeline import mask as M

    ws = kermit_ws
    before = {p.name: p.read_bytes() for p in ws.masks.glob("*.png")}
    shipped = M.DEFAULT_WEIGHTS
    with pytest.raises(UserError, match="add --confirm"):
        M.run(M.MaskConfig(confirm_weights=shipped), ws)
    with pytest.raises(UserError, match="--confirm-keep says which regions"):
        M.run(M.MaskConfig(confirm_keep="first"), ws)
    with pytest.raises(UserError, match="no use with --masks"):
        M.run(M.MaskConfig(confirm=True, masks_dir=tmp_path), ws)
    bad = tmp_path / "bad.safetensors"
    bad.write_text("not weights")
    with pytest.raises(UserError, match="--confirm-weights PATH"):
        M.run(M.MaskConfig(confirm=True, confirm_weights=bad), ws)
    assert {p.name: p.read_bytes() for p in ws.masks.glob("*.png")} == before


def test_few_targets_note_counts_the_looser_rule():
    from pipeline.select import NOTE_MAX_FLARE, few_targets_note
    from pipeline.ws_files import make_views

    stems = [f"v{i}" for i in range(6)]
    centers = np.stack([np.arange(6.0), np.zeros(6), np.zeros(6)], axis=1)
    fr = dict(zip(stems, [0.02, 0.05, 0.12, 0.14, 0.149, 0.3], strict=True))
    note = few_targets_note(make_views(stems, centers, fr, 0.10), 0.10, Path("WS"))
    # 2 of 6 targets at 10 %; at 15 % v2, v3 and v4 join: 5
    assert note is not None and "only 2 of 6 views" in note and "the other 4 have" in note
    assert f"--max-flare {NOTE_MAX_FLARE}` would train on 5" in note
    assert f"--set select.max_flare={NOTE_MAX_FLARE}" in note and "select WS" in note
    # half or more are targets: no note; nor when the looser rule adds none, nor at 15 %
    half = dict(fr, v2=0.08)
    assert few_targets_note(make_views(stems, centers, half, 0.10), 0.10, Path("WS")) is None
    far = dict(zip(stems, [0.02, 0.05, 0.2, 0.2, 0.2, 0.3], strict=True))
    assert few_targets_note(make_views(stems, centers, far, 0.10), 0.10, Path("WS")) is None
    assert few_targets_note(make_views(stems, centers, fr, 0.15), 0.15, Path("WS")) is None


def test_select_notes_few_targets(kermit_ws, tmp_path, capsys):
    ws = kermit_ws
    stems, (h, w) = _stems_and_size(ws)
    given = _write_given(tmp_path, {s: box_mask(h, w, 0.05 if i < 2 else 0.12)
                                    for i, s in enumerate(stems)})
    assert main(["mask", str(ws.root), "--masks", str(given)]) == 0
    capsys.readouterr()
    assert main(["select", str(ws.root)]) == 0
    out = " ".join(capsys.readouterr().err.split())
    assert f"only 2 of {len(stems)} views may be training targets" in out
    assert f"would train on {len(stems)}" in out
    # with the looser rule every view trains and the note is gone
    assert main(["select", str(ws.root), "--max-flare", "0.15"]) == 0
    out = " ".join(capsys.readouterr().err.split())
    assert "may be training targets" not in out
    views = json.loads(ws.views_json.read_text())
    assert all(v["target"] for v in views["views"].values())


def test_given_masks_with_one_missing_leave_the_earlier_masks_alone(tmp_path):
    """`mask --masks DIR` where DIR lacks one view's mask: one error line naming the view
    (and the file named after it with more, `<stem>_mask.png`), found before the stage
    touches the workspace: the earlier run's masks and its record stay as they were."""
    from pipeline.mask import MaskConfig, run
    from pipeline.workspace import digest_paths
    from tests.fixtures import make_plane_workspace

    ws = make_plane_workspace(tmp_path / "ws", n_views=3)
    stems = sorted(p.stem for p in ws.images.glob("*.png"))
    full, part = tmp_path / "full", tmp_path / "part"
    for d, names in ((full, stems), (part, [f"{stems[0]}_mask", *stems[1:]])):
        d.mkdir()
        for n in names:
            cv2.imwrite(str(d / f"{n}.png"), np.zeros((8, 8), np.uint8))
    run(MaskConfig(masks_dir=full), ws)
    before, record = digest_paths([ws.masks]), ws.stage_record("mask")
    with pytest.raises(UserError, match=f"no mask for view '{stems[0]}'") as e:
        run(MaskConfig(masks_dir=part), ws)
    assert f"{stems[0]}_mask.png is not named after the view alone" in str(e.value)
    assert digest_paths([ws.masks]) == before and ws.stage_record("mask") == record
    with pytest.raises(UserError, match="not a folder"):
        run(MaskConfig(masks_dir=tmp_path / "nowhere"), ws)
    assert digest_paths([ws.masks]) == before
