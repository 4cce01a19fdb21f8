"""The mask benchmarks (benchmarks/mask_*.py, clean_capture, ghost_touching, flare_veto, fmg_pads,
floor_scores, negatives_overview): what each scores, on tiny scenes and fake networks.

Moved from tests/workflows/test_eval.py, which keeps the tests on its eval scene."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
import torch

from tests.conftest import fake_fmg_probs, load_benchmark
from tests.fixtures import make_temple_workspace

pytestmark = pytest.mark.usefixtures("one_torch_thread")


def test_mask_shape_scores_light_outside_the_mask():
    """benchmarks/mask_shape.py: a mask equal to the true square scores recall, precision
    and IoU 1 and leaves outside it exactly the light added on the square's 1-pixel rim;
    grown by one pixel it takes the rim in (no light left) at a lower precision."""

    bench = load_benchmark("mask_shape")
    clean = np.full((20, 20, 3), 50, np.uint8)
    true = np.zeros((20, 20), bool)
    true[5:15, 5:15] = True
    rim = np.zeros_like(true)
    rim[4:16, 4:16] = True
    rim &= ~true
    flared = clean.copy()
    flared[true] += 30  # 100 px x 3 channels x 30
    flared[rim] += 10  # 44 px x 3 channels x 10
    res = bench.shape_scores([(true.copy(), true, flared, clean)], [0, 1])
    assert res["0"]["iou"] == res["0"]["recall"] == res["0"]["precision"] == 1.0
    assert res["0"]["light_left"] == pytest.approx(44 * 10 / (100 * 30 + 44 * 10))
    assert res["1"]["light_left"] == 0.0 and res["1"]["recall"] == 1.0
    assert res["1"]["precision"] == pytest.approx(100 / 144)
    assert res["1"]["marked_over_true"] == pytest.approx(1.44)


def test_mask_shape_perfect_fill_ceiling_weighs_misses_by_squared_error():
    """benchmarks/mask_shape.py's ``flare_psnr_ceiling``: a mask that misses only a saturated
    core scores a lower ceiling than one that misses a faint rim of more pixels, though its
    recall is higher; the ceiling is the PSNR over the true flare of the photo with the
    marked pixels made clean, and ``left_saturated`` the saturated share of its error."""

    bench = load_benchmark("mask_shape")
    clean = np.full((20, 20, 3), 100, np.uint8)
    true = np.zeros((20, 20), bool)
    true[4:16, 4:16] = True  # 144 px
    core = np.zeros_like(true)
    core[9:11, 9:11] = True  # 4 px, pushed to 255
    rim = true.copy()
    rim[5:15, 5:15] = False  # 44 px, +5 grey levels
    flared = clean.copy()
    flared[true] = 140
    flared[core] = 255
    flared[rim] = 105
    miss_core = bench.shape_scores([(true & ~core, true, flared, clean)], [0])["0"]
    miss_rim = bench.shape_scores([(true & ~rim, true, flared, clean)], [0])["0"]
    assert miss_core["recall"] == pytest.approx(140 / 144)
    assert miss_rim["recall"] == pytest.approx(100 / 144)
    mse_core = 4 * 3 * (155 / 255) ** 2 / (144 * 3)
    mse_rim = 44 * 3 * (5 / 255) ** 2 / (144 * 3)
    assert miss_core["flare_psnr_ceiling"] == pytest.approx(-10 * np.log10(mse_core))
    assert miss_rim["flare_psnr_ceiling"] == pytest.approx(-10 * np.log10(mse_rim))
    assert miss_core["flare_psnr_ceiling"] < miss_rim["flare_psnr_ceiling"]
    assert miss_core["left_saturated"] == 1.0 and miss_rim["left_saturated"] == 0.0
    whole = bench.shape_scores([(true, true, flared, clean)], [0])["0"]
    assert whole["flare_psnr_ceiling"] == float("inf") and whole["left_saturated"] == 0.0


def test_mask_dev_scenes_max_size_and_fill_holes(tmp_path, monkeypatch):
    """benchmarks/mask_dev_scenes.py: ``fill_holes`` scores the masks as `mask --fill-holes`
    writes them (a ring around an unmarked core then matches a true disc exactly), and
    ``max_size`` shrinks the photo and its true mask before the FMG sees them."""
    from pipeline import mask as M

    bench = load_benchmark("mask_dev_scenes")
    (tmp_path / "photos").mkdir()
    (tmp_path / "masks_gt").mkdir()
    yy, xx = np.mgrid[:200, :300]
    r = np.hypot(yy - 100, xx - 150)
    cv2.imwrite(str(tmp_path / "photos" / "v.png"), np.full((200, 300, 3), 90, np.uint8))
    cv2.imwrite(str(tmp_path / "masks_gt" / "v.png"), np.where(r < 40, 255, 0).astype(np.uint8))
    seen = []

    def fake_marks(model, img, cut, work_size, rays, confirm=None, scales=(1.0,), ghosts=None,
                   ray_cfg=None, pads=(), consensus=None, pads_keep="pixels"):
        seen.append(img.shape[:2])
        h, w = img.shape[:2]
        y, x = np.mgrid[:h, :w]
        rr = np.hypot(y - h / 2, x - w / 2) * 300 / w
        return (rr > 10) & (rr < 40)

    monkeypatch.setattr(M, "flare_marks", fake_marks)
    ring = bench.score_scene(None, 0.5, tmp_path, rays=False)
    filled = bench.score_scene(None, 0.5, tmp_path, rays=False, fill_holes=True)
    small = bench.score_scene(None, 0.5, tmp_path, rays=False, max_size=150, fill_holes=True)
    assert ring["flare_iou"] < 0.95 and filled["flare_iou"] > 0.99
    assert small["flare_iou"] > 0.9 and seen == [(200, 300), (200, 300), (100, 150)]
    # a folder that is not a synth scene: one line naming it, exit 2, before any scoring
    (tmp_path / "empty").mkdir()
    assert bench.main([str(tmp_path), str(tmp_path / "empty"), "--weights",
                       str(tmp_path / "w.safetensors")]) == 2
    assert seen == [(200, 300), (200, 300), (100, 150)]


def test_mask_dev_scenes_cache_runs_the_network_once_per_photo_and_changes_no_score(
        tmp_path, monkeypatch):
    """benchmarks/mask_dev_scenes.py's cache: scoring a scene with and without rays and ghost
    lines runs the network once per photo, and every score equals the uncached one."""
    from pipeline.flare_ghosts import GhostConfig

    bench = load_benchmark("mask_dev_scenes")
    (tmp_path / "photos").mkdir()
    (tmp_path / "masks_gt").mkdir()
    yy, xx = np.mgrid[:200, :300]
    r = np.hypot(yy - 100, xx - 150)
    img = np.full((200, 300, 3), 60, np.uint8)
    img[r < 12] = 255                       # a light, for the rays and the ghost lines
    for stem in ("a", "b"):
        cv2.imwrite(str(tmp_path / "photos" / f"{stem}.png"), img)
        cv2.imwrite(str(tmp_path / "masks_gt" / f"{stem}.png"),
                    np.where(r < 30, 255, 0).astype(np.uint8))
    calls = []

    def fake_probs(model, images, work_size, scales=(1.0,), pads=()):
        calls.append(len(images))
        h, w = images[0].shape[:2]
        y, x = np.mgrid[:h, :w]
        return [np.clip(1 - np.hypot(y - h / 2, x - w / 2) / 40, 0, 1).astype(np.float32)]

    fake_fmg_probs(monkeypatch, fake_probs)
    settings = [(rays, ghosts) for rays in (False, True) for ghosts in (None, GhostConfig())]
    plain = [bench.score_scene(None, 0.5, tmp_path, rays, ghosts=g) for rays, g in settings]
    assert len(calls) == 2 * len(settings)  # uncached: once per photo and setting
    calls.clear()
    cache = {}
    cached = [bench.score_scene(None, 0.5, tmp_path, rays, ghosts=g, cache=cache)
              for rays, g in settings]
    assert len(calls) == 2 and cached == plain
    assert plain[0]["flare_iou"] > 0.4  # the fake network's disc (r 20) inside the true one (r 30)


def test_floor_scores_measures_excess_and_gain(tmp_path):
    """floor_scores (the sample floor's measures, shared with benchmarks/oneshot_floor.py):
    a flared photo 30 levels above the truth inside the true flare, a de-flared one 3 above,
    gives a 20 dB gain and a tenth of the excess left; views with too little true flare and
    files with no de-flared photo are left out; the truth is resized to the output's size."""

    from workflows.research.eval.scoring import floor_scores

    dirs = {k: tmp_path / k for k in ("photos", "deflared", "decoded", "clean", "masks_gt")}
    for d in dirs.values():
        d.mkdir()
    truth = np.full((80, 120, 3), 100, np.uint8)
    m = np.zeros((80, 120), np.uint8)
    m[20:60, 30:90] = 255
    for stem, mask in (("a", m), ("b", np.zeros_like(m))):
        (dirs["photos"] / f"{stem}.jpg").write_bytes(b"")
        cv2.imwrite(str(dirs["clean"] / f"{stem}.png"), cv2.resize(truth, (240, 160)))
        cv2.imwrite(str(dirs["masks_gt"] / f"{stem}.png"),
                    cv2.resize(mask, (240, 160), interpolation=cv2.INTER_NEAREST))
        cv2.imwrite(str(dirs["decoded"] / f"{stem}.png"), truth + (mask[..., None] > 0) * 30)
        cv2.imwrite(str(dirs["deflared"] / f"{stem}.png"), truth + (mask[..., None] > 0) * 3)
    (dirs["photos"] / "README.md").write_text("not a photo")
    got = floor_scores(dirs["photos"], dirs["deflared"], dirs["decoded"], dirs["clean"],
                       dirs["masks_gt"])
    assert list(got["views"]) == ["a"]
    assert got["mean_gain"] == pytest.approx(20.0) and got["min_gain"] == pytest.approx(20.0)
    assert got["excess_in"] == pytest.approx(30.0) and got["excess_out"] == pytest.approx(3.0)
    assert got["excess_ratio"] == pytest.approx(0.1)


def test_negatives_overview_has_a_labelled_row_per_hard_negative(tmp_path):
    """benchmarks/negatives_overview.py: one row of tiles per kind of hard negative, written
    as a JPEG under its size limit."""
    from pipeline.fmg_data import HARD_NEGATIVES

    ov = load_benchmark("negatives_overview")
    (tmp_path / "backgrounds").mkdir()
    rng = np.random.default_rng(0)
    for i in range(2):
        cv2.imwrite(str(tmp_path / "backgrounds" / f"b{i}.png"),
                    rng.integers(0, 255, (100, 140, 3), dtype=np.uint8))
    img = ov.overview(tmp_path, per_kind=2)
    assert img.shape == (len(HARD_NEGATIVES) * ov.TILE, 2 * ov.TILE, 3)
    out = tmp_path / "o.jpg"
    ov.write_jpeg(out, img)
    assert 0 < out.stat().st_size <= ov.MAX_BYTES and cv2.imread(str(out)) is not None
    assert ov.main(["--data", str(tmp_path / "nowhere"), "--out", str(tmp_path / "n.jpg")]) == 2
    assert not (tmp_path / "n.jpg").exists()


def _no_network(monkeypatch) -> None:
    """The mask stage's network replaced by one that marks nothing (cut 0.5, no file
    read), so that a benchmark scores the rays alone."""
    import pipeline.provenance as prov
    from pipeline import mask as M

    fake_fmg_probs(monkeypatch, lambda model, images, work_size, scales=(1.0,), pads=():
                        [np.zeros(images[0].shape[:2], np.float32)])
    monkeypatch.setattr(M, "resolve_threshold", lambda config, weights: 0.5)
    monkeypatch.setattr(M, "load_fmg_weights", lambda path: None)
    monkeypatch.setattr(prov, "sha256", lambda path: "x")


def _one_photo_scene(folder: Path, img_bgr: np.ndarray, truth: np.ndarray) -> None:
    """A synth-like folder of one photo ``a.png`` and its true mask."""
    for d in ("photos", "masks_gt"):
        (folder / d).mkdir(parents=True)
    cv2.imwrite(str(folder / "photos" / "a.png"), img_bgr)
    cv2.imwrite(str(folder / "masks_gt" / "a.png"), np.where(truth, 255, 0).astype(np.uint8))


def _rows_on_one_photo(tmp_path: Path, monkeypatch, img_bgr: np.ndarray, truth: np.ndarray,
                       *flags: str) -> list[dict]:
    """benchmarks/mask_dev_scenes.py's rows on a one-photo scene of ``img_bgr`` (true flare
    ``truth``) with the network marking nothing and ``flags`` (e.g. ``--streak-lines``)."""
    bench = load_benchmark("mask_dev_scenes")
    _one_photo_scene(tmp_path / "s_streaks", img_bgr, truth)
    _no_network(monkeypatch)
    out = tmp_path / "rows.json"
    assert bench.main([str(tmp_path / "s_streaks"), "--weights", str(tmp_path / "w.safetensors"),
                       *flags, "--out", str(out)]) == 0
    return json.loads(out.read_text())["rows"]


def test_mask_dev_scenes_ray_rule_marks_a_lone_streak_only_when_opposite_rays_count(
        tmp_path, monkeypatch):
    """benchmarks/mask_dev_scenes.py --ray-rule: a lone streak through a light (two rays
    leaving it in opposite directions) is marked under the rule 3,8 and not under the stage's
    3,0; the rows name their rule, and mask_kind_scenes tells the settings apart."""
    from pipeline.colour import linear_to_srgb

    bench = load_benchmark("mask_dev_scenes")
    mk = load_benchmark("mask_kind_scenes")
    h, w = 256, 384
    yy, xx = np.mgrid[:h, :w].astype(np.float32)
    rng = np.random.default_rng(0)
    lin = np.full((h, w), 0.05, np.float32) + rng.normal(0, 0.002, (h, w)).astype(np.float32)
    add = 0.6 * np.exp(-np.abs(xx - 192) / 60) * np.exp(-0.5 * ((yy - 128) / 1.2) ** 2)
    lin += add
    lin[np.hypot(yy - 128, xx - 192) < 5] = 1.0  # the light
    img = (linear_to_srgb(np.clip(lin, 0, 1))[..., None].repeat(3, -1) * 255).round()
    rows = _rows_on_one_photo(tmp_path, monkeypatch, img.astype(np.uint8), add > 0.012,
                              "--ray-rule", "3,0", "--ray-rule", "3,8")
    by = {(r["rays"], None if r["ray_rule"] is None else tuple(r["ray_rule"])): r for r in rows}
    assert set(by) == {(False, None), (True, (3, 0.0)), (True, (3, 8.0))}
    assert by[True, (3, 0.0)]["flare_iou"] == 0.0  # one streak, two rays: not enough
    assert by[True, (3, 8.0)]["flare_iou"] > 0.3  # opposite rays count
    assert {mk.setting(r) for r in rows if r["rays"]} == {
        "w.safetensors@1+rays3,0", "w.safetensors@1+rays3,8"}
    for bad in ("3", "3,8,1", "0,8", "3,120"):  # argparse's one-line error, exit 2
        with pytest.raises(SystemExit) as e:
            bench.main([str(tmp_path / "s_streaks"), "--weights", "w", "--ray-rule", bad])
        assert e.value.code == 2


def test_mask_kind_scenes_judge_pools_builds(tmp_path):
    """benchmarks/mask_kind_scenes.py judge: several builds' files pooled per (file, scene),
    so the same scene name in two builds counts twice; a file lacking a setting is a
    one-line error naming it."""
    from pipeline.errors import UserError

    mk = load_benchmark("mask_kind_scenes")

    def row(weights, scene, iou, share=0.02):
        return {"weights": weights, "scales": [1.0], "rays": True, "scene": scene,
                "flare_iou": iou, "truth_share": share}

    one = [row("a.safetensors", "et_ghosts", 0.2), row("b.safetensors", "et_ghosts", 0.5)]
    two = [row("a.safetensors", "et_ghosts", 0.4), row("b.safetensors", "et_ghosts", 0.3),
           row("a.safetensors", "et_glare", 0.1, share=0.0),
           row("b.safetensors", "et_glare", 0.9, share=0.0)]
    res = mk.judge([one, two], "a.safetensors@1", "b.safetensors@1")
    assert mk.setting({**one[0], "ghost_lines": True}) == "a.safetensors@1+ghosts"
    assert mk.setting({**one[0], "ghost_lines": False}) == "a.safetensors@1"
    assert list(res["kinds"]) == ["ghosts"]  # glare has no true flare: left out
    assert res["kinds"]["ghosts"]["scenes"] == ["et_ghosts", "et_ghosts"]
    assert res["kinds"]["ghosts"]["a.safetensors@1"] == pytest.approx(0.3)
    assert res["kinds"]["ghosts"]["b.safetensors@1"] == pytest.approx(0.4)
    assert res["passes"] is True
    with pytest.raises(UserError, match="c.safetensors@1: no such setting in scores file 2"):
        mk.judge([one + [row("c.safetensors", "et_ghosts", 0.1)], two],
                 "a.safetensors@1", "c.safetensors@1")
    with pytest.raises(UserError, match="scene et_ghosts of build 1 not scored"):
        mk.judge([one[:1] + [row("b.safetensors", "et_glare", 0.2)], two],
                 "a.safetensors@1", "b.safetensors@1")
    # one build scored in two calls: FILE+FILE reads both files' rows as one build
    (tmp_path / "a.json").write_text(json.dumps({"rows": one[:1]}))
    (tmp_path / "b.json").write_text(json.dumps({"rows": one[1:]}))
    assert mk.build_rows(f"{tmp_path / 'a.json'}+{tmp_path / 'b.json'}") == one
    with pytest.raises(UserError, match="no such file"):
        mk.build_rows(f"{tmp_path / 'a.json'}+{tmp_path / 'missing.json'}")
    (tmp_path / "bad.json").write_text("not json")
    with pytest.raises(UserError, match="bad.json: not a results file"):
        mk.build_rows(str(tmp_path / "bad.json"))


def test_mask_kind_scenes_judge_with_a_target_kind():
    """`judge --target KIND`: a change aimed at one kind passes on that kind's gain with the
    other kinds and the mean held; it fails when another kind drops by more than 0.01, or its
    own gain is short (0.03, or a rule's own ``target_gain``); rows of --ghost-views are
    named +views."""
    from pipeline.errors import UserError

    mk = load_benchmark("mask_kind_scenes")

    def rows(ghosts, glare):
        return [{"weights": "a.safetensors", "scales": [1.0], "rays": True, "scene": s,
                 "flare_iou": v, "truth_share": 0.02, "ghost_lines": True, "ghost_views": c}
                for c, (g, gl) in ((False, (0.30, 0.50)), (True, (ghosts, glare)))
                for s, v in (("et_ghosts", g), ("et_glare", gl))]

    base, cand = "a.safetensors@1+ghosts", "a.safetensors@1+ghosts+views"
    ok = mk.judge([rows(0.34, 0.50)], base, cand, target="ghosts")
    assert ok["passes"] is True and ok["rule"]["target"] == "ghosts"
    assert ok["mean_gain"] == pytest.approx(0.02)
    assert mk.judge([rows(0.34, 0.50)], base, cand)["passes"] is True  # +0.02 on the mean
    assert mk.judge([rows(0.34, 0.485)], base, cand, target="ghosts")["passes"] is False
    assert mk.judge([rows(0.32, 0.50)], base, cand, target="ghosts")["passes"] is False
    smaller = mk.judge([rows(0.32, 0.50)], base, cand, target="ghosts", target_gain=0.01)
    assert smaller["passes"] is True and smaller["rule"]["target_gain"] == 0.01  # +0.02
    assert mk.judge([rows(0.305, 0.50)], base, cand, target="ghosts",
                    target_gain=0.01)["passes"] is False
    with pytest.raises(UserError, match="--target streaks: no scored scene"):
        mk.judge([rows(0.34, 0.50)], base, cand, target="streaks")


def test_mask_kind_scenes_judge_a_rules_gain_and_one_workspace():
    """`judge --mean-gain G` asks a rule's own gain of the mean; `--scene lund` judges that
    workspace's scenes alone (a name that matches none is a one-line error)."""
    from pipeline.errors import UserError

    mk = load_benchmark("mask_kind_scenes")

    def row(weights, scene, iou):
        return {"weights": weights, "scales": [1.0], "rays": True, "scene": scene,
                "flare_iou": iou, "truth_share": 0.02}

    rows = [row("a.safetensors", "et_ghosts", 0.30), row("b.safetensors", "et_ghosts", 0.35),
            row("a.safetensors", "lund_ghosts", 0.40), row("b.safetensors", "lund_ghosts", 0.39)]
    a, b = "a.safetensors@1", "b.safetensors@1"
    both = mk.judge([rows], a, b)
    assert both["mean_gain"] == pytest.approx(0.02) and both["passes"] is True
    assert mk.judge([rows], a, b, mean_gain=0.03)["passes"] is False
    assert mk.judge([rows], a, b, mean_gain=0.03)["rule"]["mean_gain"] == 0.03
    lund = mk.judge([rows], a, b, scene="lund")
    assert lund["kinds"]["ghosts"]["scenes"] == ["lund_ghosts"]
    assert lund["mean_gain"] == pytest.approx(-0.01) and lund["rule"]["scene"] == "lund"
    with pytest.raises(UserError, match="no scene named sceaux_<kind>"):
        mk.judge([rows], a, b, scene="sceaux")


def test_mask_faint_leaves_the_faint_flare_out_of_the_score():
    """benchmarks/mask_faint.py: against the strict flare, marks on the faint flare (true at
    1x only) are neither hits nor false marks, a miss there costs nothing, and marks beyond
    the true flare still count; one kind's scenes are averaged as mask_kind_scenes pools them."""
    mf = load_benchmark("mask_faint")
    truth = np.zeros((1, 10), bool)
    truth[0, :6] = True
    strict = np.zeros_like(truth)
    strict[0, :2] = True                      # the bright part: 2 pixels
    marks = np.zeros_like(truth)
    marks[0, [0, 3, 8]] = True                # a bright hit, a faint mark, a false mark
    c = mf.faint_scores(marks, truth, strict)
    assert c == {"inter": 1, "union": 3, "strict": 2, "hit": 1}  # 0, 1 and 8; 3 left out
    one = mf.faint_scores(marks, truth, truth)  # at 1x: the usual flare IoU
    assert one["inter"] == 2 and one["union"] == 7
    assert mf.pooled([c, one])["flare_iou"] == pytest.approx(3 / 10)
    assert mf.pooled([c])["recall"] == pytest.approx(0.5)
    empty = mf.faint_scores(np.zeros_like(truth), truth, np.zeros_like(truth))
    assert mf.pooled([empty]) == {"flare_iou": None, "recall": None, "strict_pixels": 0}
    k = mf.kind_scores([[c], [one], [empty]])
    assert k["scenes"] == 2 and k["mean_scene_iou"] == pytest.approx((1 / 3 + 2 / 7) / 2)
    assert mf.kind_of("lund_streaks") == "streaks" and mf.kind_of("lund_synth") is None
    assert mf.kind_of("streaks") is None


def test_mask_views_scenes_scores_a_posed_workspace_without_writing_into_it(tmp_path):
    """benchmarks/mask_views_scenes.py --posed: the mask stage runs with each setting in a
    shared copy under WORK (the base and the other photos' check), one row per setting with
    every view scored; nothing is written into the given workspace."""

    from gnfr.fmg import build_fmg, save_fmg, tiny_config
    from pipeline.workspace import digest_paths
    from tests.fixtures import make_temple_workspace

    bench = load_benchmark("mask_views_scenes")
    ws = make_temple_workspace(tmp_path / "ws", n_views=3, scale=0.5)
    torch.manual_seed(0)
    weights = save_fmg(tmp_path / "tiny.safetensors", build_fmg(tiny_config()))
    before = digest_paths([ws.root])
    rows = bench.score_workspace(ws.root, tmp_path / "work", weights, clean=False, posed=True)
    assert digest_paths([ws.root]) == before
    assert [r["setting"] for r in rows] == list(bench.SETTINGS)
    stems = sorted(p.stem for p in ws.images.glob("*.png"))
    for r in rows:
        assert r["folder"] == "posed" and sorted(r["per_view"]) == stems
        assert r["truth_share"] == 0 and r["flare_iou"] == 0
        assert r["marked"] == pytest.approx(r["marked_outside"])
    assert rows[1]["ghost_views"] and rows[1]["marked"] >= rows[0]["marked"]
    assert (tmp_path / "work" / "ws_posed.ws" / "masks_ghosts").is_dir()
    # --ray-opposite: a third setting, the default's with the rule for streaks through a light
    opp = {"ghost_views_opp": {**bench.SETTINGS["ghost_views"], "ray_opposite": 8.0}}
    [row] = bench.score_workspace(ws.root, tmp_path / "work", weights, clean=False, posed=True,
                                  settings=opp)
    assert row["setting"] == "ghost_views_opp" and row["ray_opposite"] == 8.0
    assert rows[1]["ray_opposite"] is None and digest_paths([ws.root]) == before


def test_clean_capture_counts_what_the_job_changed():
    """benchmarks/clean_capture.py: an untouched photo changed nothing; a patch brightened
    by 10 of 255 is the changed share and sets the PSNR (10/255 there: 28.1 dB)."""
    cc = load_benchmark("clean_capture")
    rng = np.random.default_rng(0)
    photo = rng.integers(20, 200, (40, 50, 3), dtype=np.uint8)
    mask = np.zeros((39, 49), bool)
    mask[:13, :7] = True
    same = cc.view_row(photo, photo.copy(), mask)
    assert same["changed"] == 0 and same["psnr"] is None and same["psnr_changed"] is None
    assert same["marked"] == round(float(mask.mean()), 5)
    out = photo.copy()
    out[:10, :20] += 10
    row = cc.view_row(photo, out, mask)
    assert row["changed"] == 0.1
    assert abs(row["psnr_changed"] - 20 * np.log10(255 / 10)) < 0.01
    assert row["psnr"] > row["psnr_changed"]


def test_clean_capture_touching_counts_regions_next_to_the_network_marks():
    """A region the views added that touches the network's marks counts whole; one apart
    does not."""
    cc = load_benchmark("clean_capture")
    own = np.zeros((20, 30), bool)
    own[5:10, 5:10] = True
    added = np.zeros_like(own)
    added[5:10, 10:14] = True      # touches own: 20 pixels
    added[15:18, 20:25] = True     # apart: 15 pixels
    assert cc.touching(added, own) == 20
    assert cc.touching(np.zeros_like(own), own) == 0


def test_ghost_touching_splits_the_added_pixels():
    """benchmarks/ghost_touching.py: added pixels next to the network's marks and apart,
    each counted in and out of the true flare."""
    gt = load_benchmark("ghost_touching")
    own = np.zeros((20, 30), bool)
    own[5:10, 5:10] = True
    added = np.zeros_like(own)
    added[5:10, 10:14] = True      # touches own: 20 pixels, 10 of them true
    added[15:18, 20:25] = True     # apart: 15 pixels, all true
    truth = np.zeros_like(own)
    truth[5:10, 12:14] = True
    truth[15:18, 20:25] = True
    assert gt.split_added(added, own, truth) == {"touching": 20, "touching_true": 10,
                                                  "apart": 15, "apart_true": 15}


def test_flare_veto_checks_its_inputs_in_one_line_before_any_stage(tmp_path, capsys):
    """benchmarks/flare_veto.py: a folder that is not a synth scene, a clean folder that is
    not posed, and a bad --depth-set are each one line, exit 2, before anything runs."""
    fv = load_benchmark("flare_veto")
    work = tmp_path / "w"
    for argv, needle in (([ "--scene", str(tmp_path / "nope")], "not a synth scene"),
                         (["--clean", str(tmp_path)], "not a posed workspace"),
                         (["--depth-set", "depth.sgm=2,1"], "P1 <= P2")):
        assert fv.main([*argv, "--work", str(work)]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and needle in err
    assert not work.exists()


def test_mask_dev_scenes_streak_lines_rows_mark_a_streak_the_rays_miss(tmp_path, monkeypatch):
    """benchmarks/mask_dev_scenes.py --streak-lines: each ray setting scored again with the
    streak lines; a thin streak through a light (two rays, under the rule's three) is marked
    only there, and mask_kind_scenes names the rows ``+lines``."""
    from tests.pipeline.test_flare_lines import _background, _photo, _streak

    mk = load_benchmark("mask_kind_scenes")
    streak = _streak(1.0)
    img = (_photo(_background() + streak)[..., ::-1] * 255).round().astype(np.uint8)
    rows = _rows_on_one_photo(tmp_path, monkeypatch, img, streak > 0.012, "--streak-lines")
    by = {(r["rays"], r["streak_lines"]): r for r in rows}
    assert set(by) == {(False, False), (True, False), (True, True)}
    assert by[True, False]["flare_iou"] == 0.0
    assert by[True, True]["flare_iou"] > 0.4
    assert {mk.setting(r) for r in rows if r["rays"]} == {"w.safetensors@1",
                                                          "w.safetensors@1+lines"}


def test_streak_lines_need_the_rays():
    """mask --streak-lines with --no-rays or --masks, and fmg eval's without --rays: one
    line each, before anything runs."""
    from pipeline.errors import UserError
    from pipeline.mask import MaskConfig, ray_config
    from pipeline.options import validate
    from workflows.research.fmg_eval import check_ray_rule

    assert ray_config(MaskConfig(streak_lines=True)).lines
    assert not ray_config(MaskConfig()).lines
    for bad in (MaskConfig(streak_lines=True, rays=False),
                MaskConfig(streak_lines=True, masks_dir=Path("m"))):
        with pytest.raises(UserError, match="--streak-lines"):
            validate(bad)

    class Cfg:
        rays, ray_min, ray_opposite, streak_lines = False, None, None, True

    with pytest.raises(UserError, match="--streak-lines"):
        check_ray_rule(Cfg())


def test_mask_time_rays_rows_time_the_rays_with_and_without_the_streak_lines(tmp_path):
    """benchmarks/mask_time.py --rays: one row per weight file, then one for the rays at
    the stage's rule and one with the streak lines, each with a time per view."""
    from tests.pipeline.test_flare_lines import _background, _photo, _streak

    bench = load_benchmark("mask_time")
    (tmp_path / "p").mkdir()
    img = (_photo(_background() + _streak(1.0))[..., ::-1] * 255).round().astype(np.uint8)
    cv2.imwrite(str(tmp_path / "p" / "a.png"), img)
    w = Path(__file__).resolve().parents[2] / "gnfr" / "weights" / "fmg_small.safetensors"
    out = tmp_path / "t.json"
    assert bench.main([str(tmp_path / "p"), "--weights", str(w), "--repeat", "1", "--rays",
                       "--out", str(out)]) == 0
    rows = json.loads(out.read_text())["rows"]
    assert [r.get("rays") for r in rows] == [None, "default", "streak_lines"]
    assert all(r["median_s_per_view"] > 0 and r["views"] == 1 for r in rows)
    assert bench.main([str(tmp_path / "p"), "--weights", str(w), "--repeat", "1", "--rays",
                       "--streak-scales", "1,0.25", "--out", str(out)]) == 0
    rows = json.loads(out.read_text())["rows"]
    assert [r.get("rays") for r in rows][-1] == "streak_lines_at_1,0.25"
    with pytest.raises(SystemExit):  # the scales time the rays' lines: --rays needed
        bench.main([str(tmp_path / "p"), "--weights", str(w), "--streak-scales", "0.25"])


def test_mask_time_bad_folders_are_one_line_errors(tmp_path, capsys):
    """benchmarks/mask_time.py given a missing folder, an empty one or an unreadable photo:
    one `error:` line naming it, exit 2."""
    bench = load_benchmark("mask_time")
    (tmp_path / "empty").mkdir()
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "x.jpg").write_text("junk")
    for folder, says in (("missing", "no such folder"), ("empty", "no photos"),
                         ("bad", "x.jpg is not a readable image")):
        assert bench.main([str(tmp_path / folder), "--weights", "w.safetensors"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("error: ") and says in err[0], err


def test_mask_fusion_features_of_a_clean_posed_workspace(tmp_path):
    """benchmarks/mask_fusion.py features --posed: every view's features in their order, the
    truth empty, the stage's own mask kept; nothing written into the given workspace."""
    from pipeline.workspace import digest_paths

    bench = load_benchmark("mask_fusion")
    ws = make_temple_workspace(tmp_path / "ws", n_views=3, scale=0.5)
    before = digest_paths([ws.root])
    bench.features([], [ws.root], tmp_path / "work")
    assert digest_paths([ws.root]) == before
    files = sorted((tmp_path / "work" / "feats" / "ws_posed").glob("*.npz"))
    assert len(files) == 3
    d = np.load(files[0])
    h, w = d["truth"].shape
    assert d["feats"].shape == (len(bench.FEATURES), h, w) and not d["truth"].any()
    assert np.array_equal(d["feats"][bench.FEATURES.index("stage_mask")] > 0, d["base"])


def test_mask_fusion_folds_hold_one_workspace_out(tmp_path, monkeypatch):
    """benchmarks/mask_fusion.py folds: fitted on two workspaces' scenes, scored on the
    third's, with and without the other photos' features; a fusion that can read the flare
    off its features finds it on the held-out scenes, and the clean workspace's share is
    reported."""
    bench = load_benchmark("mask_fusion")
    monkeypatch.setattr(bench, "STEPS", 300)
    monkeypatch.setattr(bench, "NEGATIVES", 200)
    rng = np.random.default_rng(0)
    feats = tmp_path / "feats"

    def view(folder, i, flared=True):
        truth = np.zeros((24, 24), bool)
        if flared:
            truth[rng.integers(0, 12):, rng.integers(0, 12):][:8, :8] = True
        x = rng.normal(0, 1, (len(bench.FEATURES), 24, 24))
        x[0] = np.where(truth, 4.0, -4.0) + rng.normal(0, 0.5, truth.shape)  # the logit
        base = x[0] > 3.5                                                    # a stricter stage
        x[bench.FEATURES.index("stage_mask")] = base
        (feats / folder).mkdir(parents=True, exist_ok=True)
        np.savez(feats / folder / f"{i}.npz", feats=x.astype(np.float16), truth=truth, base=base)

    for scene in ("aa", "bb", "cc"):
        for kind in ("ghosts", "streaks"):
            for i in range(2):
                view(f"b1_{scene}_{kind}", i)
        view(f"{scene}_ws_posed", 0, flared=False)
    rows = bench.folds(tmp_path, [0])
    assert [(r["held_out"], r["without"]) for r in rows] == [
        (s, w) for s in ("aa", "bb", "cc") for w in ([], list(bench.CROSS_VIEW))]
    for r in rows:
        assert set(r["stage"]) == set(r["fusion"]) == {"ghosts", "streaks"}
        assert r["fusion_mean"] > 0.95 and r["fusion_mean"] > r["stage_mean"]
        assert r["clean_fusion"] < 0.01 and r["cut"] in bench.CUTS
    assert bench.scene_of("b1_lund_streaks") == "lund"
    assert bench.kind_means({"b_x_ghosts": 0.2, "c_x_ghosts": 0.4, "b_x_glare": None}) == {
        "ghosts": pytest.approx(0.3)}
    assert bench.pooled_iou([(np.zeros((2, 2), bool), np.zeros((2, 2), bool))]) is None


def test_fmg_pads_benchmark_combines_its_passes(tmp_path, capsys):
    """benchmarks/fmg_pads.py: each pass's marks and the mean / median / min of the four
    maps cut at the same threshold; a folder without its images is one line, exit 2."""
    bench = load_benchmark("fmg_pads")
    probs = {"plain": np.array([[0.9, 0.9, 0.2]]), "reflect": np.array([[0.9, 0.4, 0.6]]),
             "replicate": np.array([[0.8, 0.9, 0.6]]), "constant": np.array([[0.7, 0.9, 0.6]])}
    marks = bench.combined_marks(probs, 0.5)
    assert marks["plain"].tolist() == [[True, True, False]]
    assert marks["min"].tolist() == [[True, False, False]]  # every pass must mark it
    assert marks["median"].tolist() == [[True, True, True]]
    assert marks["mean"].tolist() == [[True, True, False]]  # 0.5 is not above the cut
    assert marks["regions"].tolist() == [[True, True, False]]  # the min's region, whole
    from pipeline.mask import regions_touching

    lone = regions_touching(np.array([[1, 1, 0, 1]], bool), np.array([[0, 1, 0, 0]], bool))
    assert lone.tolist() == [[True, True, False, False]]  # a region the min never kept goes
    assert bench.main(["--clean", str(tmp_path)]) == 2
    assert "no images/ folder" in capsys.readouterr().err


def test_mask_dev_scenes_light_cores_rows_mark_the_streak_of_a_lamp_with_saturated_arms(
        tmp_path, monkeypatch):
    """benchmarks/mask_dev_scenes.py --light-cores: each ray setting scored again with lamps
    found by their core; a lamp whose saturated streak makes its region too ragged to be a
    light has its streak marked only there, and mask_kind_scenes names the rows ``+cores``."""
    from tests.pipeline.test_flare_rays import S, _lamp_with_a_saturated_streak, _srgb

    mk = load_benchmark("mask_kind_scenes")
    lin, streak = _lamp_with_a_saturated_streak()
    img = (_srgb(lin)[..., ::-1] * 255).round().astype(np.uint8)
    assert img.shape[:2] == (S, S)
    rows = _rows_on_one_photo(tmp_path, monkeypatch, img, streak > 0.012, "--light-cores")
    by = {(r["rays"], r["light_cores"]): r for r in rows}
    assert set(by) == {(False, False), (True, False), (True, True)}
    assert by[True, False]["flare_iou"] == 0.0
    assert by[True, True]["flare_iou"] > 0.3
    assert {mk.setting(r) for r in rows if r["rays"]} == {"w.safetensors@1",
                                                          "w.safetensors@1+cores"}


def test_light_cores_reach_the_rays_and_need_the_network():
    """mask --light-cores sets the rays' light finder; with --masks, and fmg eval's without
    --rays, one line each, before anything runs; mask_views_scenes.py --light-cores scores
    today's default and it, those two only."""
    from pipeline.errors import UserError
    from pipeline.mask import MaskConfig, ray_config
    from pipeline.options import validate
    from workflows.research.fmg_eval import check_ray_rule

    assert ray_config(MaskConfig(light_cores=True)).cores
    assert not ray_config(MaskConfig()).cores
    with pytest.raises(UserError, match="--light-cores"):
        validate(MaskConfig(light_cores=True, masks_dir=Path("m")))

    class Cfg:
        rays, ray_min, ray_opposite, streak_lines, light_cores = False, None, None, None, True

    with pytest.raises(UserError, match="--light-cores"):
        check_ray_rule(Cfg())
    bench = load_benchmark("mask_views_scenes")
    with pytest.raises(SystemExit):
        bench.main(["--posed", "x", "--work", "w", "--light-cores", "--streak-lines"])
    with pytest.raises(SystemExit):
        bench.main(["--posed", "x", "--work", "w", "--light-cores", "--fill-holes"])


def test_mask_kind_scenes_names_filled_holes():
    """mask_kind_scenes.py's setting names a row scored with the enclosed holes filled
    (``+holes``), so a judge never pools such rows with the plain masks' rows."""
    kinds = load_benchmark("mask_kind_scenes")
    row = {"weights": "w/fmg_candidate_F26.safetensors", "scales": [1.0],
           "pads": ["reflect", "replicate", "constant"]}
    assert kinds.setting(row) == "fmg_candidate_F26.safetensors@1+pads=reflect,replicate,constant"
    assert (kinds.setting({**row, "fill_holes": True})
            == "fmg_candidate_F26.safetensors@1+holes+pads=reflect,replicate,constant")



def test_mask_views_scenes_streak_scales_scores_the_lines_and_them_scaled(tmp_path,
                                                                           monkeypatch):
    """mask_views_scenes.py --streak-lines --streak-scales 1,0.25 scores today's default with
    the streak lines and with them at those scales too, those two only, the second's mean
    share over the first's its candidate_added; --streak-scales alone or out of range stops
    with a usage error."""
    bench = load_benchmark("mask_views_scenes")
    seen: dict = {}

    def fake(scene, work, weights, clean, posed=False, settings=None):
        seen.update(settings)
        return [{"setting": n, "folder": "posed", "flare_iou": 0.0, "marked": 0.01 * (i + 1),
                 "per_view": {"a": {"marked": 0.01 * (i + 1)}}}
                for i, n in enumerate(settings)]

    monkeypatch.setattr(bench, "score_workspace", fake)
    out = tmp_path / "o.json"
    assert bench.main(["--posed", str(tmp_path), "--work", str(tmp_path / "w"),
                       "--streak-lines", "--streak-scales", "1,0.25", "--out", str(out)]) == 0
    assert list(seen) == ["ghost_views_pads_lines", "ghost_views_pads_lines_scaled"]
    base, scaled = seen.values()
    assert base["streak_lines"] and base["pads"] == ("reflect", "replicate", "constant")
    assert scaled == {**base, "streak_scales": (1.0, 0.25)}
    rec = json.loads(out.read_text())
    assert rec["candidate_added"] == pytest.approx(0.01)
    for bad in (["--streak-scales", "0.25"], ["--streak-lines", "--streak-scales", "1,0"],
                ["--streak-lines", "--streak-scales", "x"]):
        with pytest.raises(SystemExit):
            bench.main(["--posed", "x", "--work", "w", *bad])


def test_scene_luminance_weights_and_folder_range(tmp_path):
    """benchmarks/scene_luminance.py: a grey photo's luminance is its grey (the weights sum
    to one), green counts most, and a folder's range spans its photos' medians."""
    sl = load_benchmark("scene_luminance")
    grey = np.full((8, 8, 3), 0.25, np.float32)
    assert sl.luminance_stats(grey) == pytest.approx((0.25, 0.25), abs=1e-6)
    green, red = np.zeros((8, 8, 3), np.float32), np.zeros((8, 8, 3), np.float32)
    green[..., 1], red[..., 0] = 1.0, 1.0
    assert sl.luminance_stats(green)[0] > 0.7 > 0.25 > sl.luminance_stats(red)[0]
    for name, value in (("a.png", 51), ("b.png", 204)):
        cv2.imwrite(str(tmp_path / name), np.full((8, 8, 3), value, np.uint8))
    stats = sl.folder_stats(tmp_path)
    assert sorted(stats["photos"]) == ["a.png", "b.png"]
    assert stats["median_min"] == pytest.approx(0.2, abs=1e-6)
    assert stats["median_max"] == pytest.approx(0.8, abs=1e-6)


def test_scene_luminance_bad_folders_one_line(tmp_path, capsys):
    """benchmarks/scene_luminance.py: a missing folder and a folder without photos each end
    the run with one `error:` line and exit 2, nothing written."""
    sl = load_benchmark("scene_luminance")
    (tmp_path / "empty").mkdir()
    for folder, needle in ((tmp_path / "missing", "is not a folder"),
                           (tmp_path / "empty", "holds no photos")):
        assert sl.main([str(folder), "--out", str(tmp_path / "out.json")]) == 2
        err = [ln for ln in capsys.readouterr().err.splitlines() if ln]
        assert len(err) == 1 and err[0].startswith("error:") and needle in err[0], err
    assert not (tmp_path / "out.json").exists()
