"""The A/B scripts' rules and judges (finetune_ab, fmg_photo_ab and the rules it applies,
network_scale_ab, novel_loo, the mixed-size and unseen judges): each part of a rule, on made-up
arms.

Moved from tests/workflows/test_eval.py, which keeps the tests on its eval scene."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from tests.conftest import load_benchmark

pytestmark = pytest.mark.usefixtures("one_torch_thread")


def test_finetune_ab_names_its_second_arm_by_the_values():
    """benchmarks/finetune_ab.py names the second arm's workspace and result key by the
    values set: numbers as written, weight files by their stem."""
    bench = load_benchmark("finetune_ab")
    sets = bench.parse_sets(["lr_scale=0.5", "init=gnfr/weights/gnfr_paper.safetensors"])
    assert sets == {"lr_scale": 0.5, "init": "gnfr/weights/gnfr_paper.safetensors"}
    assert [bench.arm_label(v) for v in sets.values()] == ["0.5", "gnfr_paper"]


def test_finetune_ab_bad_scene_or_seed_is_one_line_and_exit_2(tmp_path, monkeypatch, capsys):
    """benchmarks/finetune_ab.py on a folder that is no synth scene, or with a negative
    seed: one line on stderr, exit 2, no work folder made."""
    bench = load_benchmark("finetune_ab")
    for extra in ([], ["--seed", "-1"]):
        monkeypatch.setattr("sys.argv", ["finetune_ab.py", str(tmp_path / "none"), "--set",
                                         "edge_rays=0.5", "--work", str(tmp_path / "w"),
                                         *extra])
        assert bench.main() == 2
        err = capsys.readouterr().err.strip()
        assert err.startswith("error: ") and len(err.splitlines()) == 1, err
    assert not (tmp_path / "w").exists()


def _ab_run(scene: str, seed: int, delta: dict, speed: float = 1.0) -> dict:
    """A finetune_ab.py result file: base and candidate rows, the candidate moved by delta."""
    base = {"flare_region_psnr": 20.0, "inputs_psnr": 30.0, "inputs_ssim": 0.9,
            "heldout_psnr": 17.0, "heldout_ssim": 0.6, "train": {"it_per_s": 5.0}}
    cand = {k: v + delta.get(k, 0.0) for k, v in base.items() if k != "train"}
    cand["train"] = {"it_per_s": 5.0 * speed}
    return {"scene": f"/dev/{scene}_synth", "seed": seed, "base": base, "edge_rays-0.5": cand}


def test_finetune_ab_judge_applies_each_part_of_its_rule(tmp_path, capsys, monkeypatch):
    """benchmarks/finetune_ab_judge.py: seed means, then scene means; a mean gain passes
    (a) yet one scene's loss beyond the limit fails (b); SSIM of the novel views counts in
    (c); the slowdown (d) is the mean of per-run ratios; unequal seeds are one line, exit 2."""
    bench = load_benchmark("finetune_ab_judge")
    limits = {"min_region_gain": 0.10, "max_region_loss": 0.20, "max_photo_loss": 0.05,
              "max_novel_loss": 0.10, "max_ssim_loss": 0.002, "max_slowdown": 0.10}
    good = [_ab_run(s, seed, {"flare_region_psnr": g + 0.1 * (seed - 3)}, 0.95)
            for s, g in (("a", 0.3), ("b", 0.1), ("c", 0.0)) for seed in (2, 3, 4)]
    v = bench.judge(good, "edge_rays-0.5", limits)
    assert v["passes"] and v["seeds"] == [2, 3, 4] and v["resumed_runs"] == []
    good[4]["edge_rays-0.5"]["provenance"] = {"trained": {"resumed": [{"at_step": 1750}]}}
    assert bench.judge(good, "edge_rays-0.5", limits)["resumed_runs"] == ["b_synth seed 3"]
    assert v["mean"]["region"] == pytest.approx(0.4 / 3)
    assert v["mean"]["speed"] == pytest.approx(-0.05)
    one_loses = [_ab_run(s, seed, {"flare_region_psnr": g}) for s, g in
                 (("a", 0.9), ("b", 0.1), ("c", -0.25)) for seed in (2, 3, 4)]
    v = bench.judge(one_loses, "edge_rays-0.5", limits)
    assert v["parts"]["a_region_gain"] and not v["parts"]["b_no_scene_region_loss"]
    assert not v["passes"]
    ssim = [_ab_run(s, 2, {"flare_region_psnr": 0.2, "heldout_ssim": -0.003}) for s in "abc"]
    v = bench.judge(ssim, "edge_rays-0.5", limits)
    assert not v["parts"]["c_ssim"] and v["parts"]["c_novel"] and not v["passes"]
    slow = [_ab_run(s, 2, {"flare_region_psnr": 0.2}, 0.85) for s in "abc"]
    assert not bench.judge(slow, "edge_rays-0.5", limits)["parts"]["d_speed"]
    files = []
    for i, run in enumerate(good[:3] + [_ab_run("b", 2, {})]):
        files.append(tmp_path / f"r{i}.json")
        files[-1].write_text(json.dumps(run))
    monkeypatch.setattr("sys.argv", ["finetune_ab_judge.py", *map(str, files),
                                     "--arm", "edge_rays-0.5"])
    assert bench.main() == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and "different seeds" in err and len(err.splitlines()) == 1
    monkeypatch.setattr("sys.argv", ["finetune_ab_judge.py", str(tmp_path / "none.json"),
                                     "--arm", "edge_rays-0.5"])
    assert bench.main() == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"error: {tmp_path / 'none.json'}: ") and len(err.splitlines()) == 1
    unseeded = _ab_run("a", 2, {})
    del unseeded["seed"]
    with pytest.raises(ValueError, match="records no seed"):
        bench.judge([unseeded], "edge_rays-0.5", limits)


def _photo_ab():
    return load_benchmark("fmg_photo_ab")


def test_fmg_photo_rule_stops_at_the_first_failing_part():
    """The photo rule of an FMG candidate (benchmarks/fmg_photo_ab.py): a mean flare gain
    with one scene below -0.20 dB fails (b), not (a); a uniform +0.15 dB passes; a flare
    gain that costs the novel views 0.2 dB fails (d); a loss of 0.01 SSIM fails (c)."""
    m = _photo_ab()
    base = {s: {"psnr": 30.0, "psnr_flare": 20.0, "ssim": 0.95, "held": 17.0} for s in "xyz"}

    def cand(**by_scene):
        return {s: {**base[s], **by_scene.get(s, {})} for s in base}

    up = {s: {"psnr_flare": 20.15} for s in "xyz"}
    assert m.photo_rule(cand(**up), base)["decision"] == "passes"
    mixed = {"x": {"psnr_flare": 21.0}, "y": {"psnr_flare": 19.7}, "z": {}}
    got = m.photo_rule(cand(**mixed), base)
    assert got["parts"]["a"] and not got["parts"]["b"] and got["decision"] == "fails (b)"
    assert got["mean"]["psnr_flare"] == pytest.approx(0.7 / 3)
    held = {s: {"psnr_flare": 20.2, "held": 16.8} for s in "xyz"}
    assert m.photo_rule(cand(**held), base)["decision"] == "fails (d)"
    ssim = {s: {"psnr_flare": 20.2, "ssim": 0.94} for s in "xyz"}
    assert m.photo_rule(cand(**ssim), base)["decision"] == "fails (c)"


def test_novel_rule_judges_the_video_and_guards_the_photos():
    """``--rule novel``: +0.15 dB novel views everywhere passes; the same with one scene
    -0.3 dB fails (b); a novel gain that costs the flare region 0.1 dB fails (c); a flare
    gain alone does not pass (a)."""
    m = _photo_ab()
    base = {s: {"psnr": 30.0, "psnr_flare": 20.0, "ssim": 0.95, "held": 17.0} for s in "xyz"}

    def cand(**by_scene):
        return {s: {**base[s], **by_scene.get(s, {})} for s in base}

    up = {s: {"held": 17.15} for s in "xyz"}
    assert m.photo_rule(cand(**up), base, "novel")["decision"] == "passes"
    one_down = {"x": {"held": 17.7}, "y": {"held": 17.3}, "z": {"held": 16.7}}
    got = m.photo_rule(cand(**one_down), base, "novel")
    assert got["parts"]["a"] and got["decision"] == "fails (b)"
    costly = {s: {"held": 17.3, "psnr_flare": 19.9} for s in "xyz"}
    assert m.photo_rule(cand(**costly), base, "novel")["decision"] == "fails (c)"
    flare_only = {s: {"psnr_flare": 21.0} for s in "xyz"}
    assert m.photo_rule(cand(**flare_only), base, "novel")["decision"] == "fails (a)"
    assert m.photo_rule(cand(**flare_only), base)["decision"] == "passes"


def test_frames_rule_asks_a_structure_gain_of_the_novel_views_and_no_scene_lost():
    """``--rule frames`` (a depth change for the novel frames alone): SSIM +0.01 on every
    scene passes whatever the photos do; a mean gain with one scene's SSIM -0.003 fails (a),
    as does +0.005 everywhere; a scene's novel PSNR -0.11 dB fails (b), and so does the mean
    -0.06 dB with no scene under -0.10."""
    m = _photo_ab()
    base = {s: {"psnr": 30.0, "psnr_flare": 20.0, "ssim": 0.95, "held": 17.0, "held_ssim": 0.5}
            for s in "xyz"}

    def cand(**by_scene):
        return {s: {**base[s], **by_scene.get(s, {})} for s in base}

    up = {s: {"held_ssim": 0.51, "psnr_flare": 19.0} for s in "xyz"}
    assert m.photo_rule(cand(**up), base, "frames")["decision"] == "passes"
    one_down = {"x": {"held_ssim": 0.53}, "y": {"held_ssim": 0.497}, "z": {"held_ssim": 0.51}}
    got = m.photo_rule(cand(**one_down), base, "frames")
    assert got["mean"]["held_ssim"] > 0.008 and got["decision"] == "fails (a)"
    small = {s: {"held_ssim": 0.505} for s in "xyz"}
    assert m.photo_rule(cand(**small), base, "frames")["decision"] == "fails (a)"
    scene_loss = {**up, "x": {"held_ssim": 0.51, "held": 16.89}}
    assert m.photo_rule(cand(**scene_loss), base, "frames")["decision"] == "fails (b)"
    mean_loss = {s: {"held_ssim": 0.51, "held": 16.94} for s in "xyz"}
    got = m.photo_rule(cand(**mean_loss), base, "frames")
    assert got["parts"] == {"a": True, "b": False}


def test_speed_rule_asks_no_gain_and_allows_only_a_seeds_spread_of_loss():
    """``--rule speed`` (a change for speed): the same numbers pass; -0.04 dB in every flare
    region passes, -0.06 fails (a), as does one scene's -0.25 with the mean -0.03; the whole
    photo -0.06 dB or its SSIM -0.003 fails (b); novel views -0.11 dB on the mean fails (c),
    while one scene's -0.25 with the mean -0.05 passes (no per-scene check of the novel
    views: two held-out cameras a scene)."""
    m = _photo_ab()
    base = {s: {"psnr": 30.0, "psnr_flare": 20.0, "ssim": 0.95, "held": 17.0} for s in "xyz"}

    def cand(**by_scene):
        return {s: {**base[s], **by_scene.get(s, {})} for s in base}

    def verdict(**by_scene):
        return m.photo_rule(cand(**by_scene), base, "speed")["decision"]

    assert verdict() == "passes"
    assert verdict(**{s: {"psnr_flare": 19.96} for s in "xyz"}) == "passes"
    assert verdict(**{s: {"psnr_flare": 19.94} for s in "xyz"}) == "fails (a)"
    assert verdict(x={"psnr_flare": 19.75}, y={"psnr_flare": 20.08},
                   z={"psnr_flare": 20.08}) == "fails (a)"
    assert verdict(**{s: {"psnr": 29.94} for s in "xyz"}) == "fails (b)"
    assert verdict(**{s: {"ssim": 0.947} for s in "xyz"}) == "fails (b)"
    assert verdict(**{s: {"held": 16.89} for s in "xyz"}) == "fails (c)"
    assert verdict(x={"held": 16.75}, y={"held": 17.05}, z={"held": 17.05}) == "passes"


def test_photo_ab_arms_pass_render_options_to_both_renders(tmp_path, monkeypatch):
    """``run --render-args`` and ``rerender --render-args`` give the options to both renders
    (the de-flared photos and the held-out cameras); ``rerender`` without depth options
    keeps the base arm's depth maps (no depth step); ``rerender --novel-args`` gives its
    options to the held-out cameras' render alone, ``--inputs-args`` to the de-flared
    photos' alone."""
    m = _photo_ab()
    steps = {}
    monkeypatch.setattr(m, "_run_and_score",
                        lambda synth, ws, st, out, keys=False: steps.setdefault(ws.name, st)
                        and out)
    synth = tmp_path / "sceaux_synth"
    (synth / "eval.ws" / "variants").mkdir(parents=True)
    m.run_arm(synth, "c", tmp_path / "w.safetensors", 3, tmp_path, render_args=["--bf16"])
    renders = [st for st in steps["sceaux_c_s3.ws"] if st[0] == "render"]
    assert len(renders) == 2 and all(st[-1] == "--bf16" for st in renders)
    (tmp_path / "sceaux_c_s3.ws" / "model").mkdir()
    m.rerender_arm(synth, "c", "r", 3, tmp_path, [], ["--bf16"])
    assert [st[0] for st in steps["sceaux_r_s3.ws"]] == ["render", "render"]
    assert all(st[-1] == "--bf16" for st in steps["sceaux_r_s3.ws"])
    m.rerender_arm(synth, "c", "d", 3, tmp_path, ["--sgm", "0.1,1"])
    assert [st[0] for st in steps["sceaux_d_s3.ws"]] == ["depth", "render", "render"]
    m.rerender_arm(synth, "c", "n", 3, tmp_path, [], [], ["--sources-equal-below", "1"])
    photos, held = steps["sceaux_n_s3.ws"]
    assert "--sources-equal-below" not in photos and held[-2:] == ["--sources-equal-below", "1"]
    m.rerender_arm(synth, "c", "i", 3, tmp_path, [], [], [], inputs_args=["--n-sources", "12"])
    photos, held = steps["sceaux_i_s3.ws"]
    assert photos[-2:] == ["--n-sources", "12"] and "--n-sources" not in held
    # --keys: a third render, the photos' own cameras as a novel path, with the novel options
    (synth / "cameras_gt.json").write_text("{}")
    monkeypatch.setattr(m, "keys_path_json", lambda s, ws: ws / "eval" / "input_cameras.json")
    m.rerender_arm(synth, "c", "k", 3, tmp_path, [], [], ["--nearest-source"], keys=True)
    keys = steps["sceaux_k_s3.ws"][2]
    assert keys[2:4] == ["--path", str(tmp_path / "sceaux_k_s3.ws" / "eval" /
                                       "input_cameras.json")]
    assert keys[-1] == "--nearest-source" and "--nearest-source" not in steps["sceaux_k_s3.ws"][0]


def test_depth_rule_holds_the_photos_per_scene_and_the_novel_views_on_the_mean(tmp_path, capsys):
    """``--rule depth`` (a depth stage change, the model fixed): +0.06 dB in every flare
    region passes; a mean gain with one scene's flare region -0.06 dB fails (a), as does a
    scene's SSIM -0.003; novel views' mean SSIM -0.003 fails (b). ``rerender`` without the
    base arm's workspace is one line, exit 2."""
    m = _photo_ab()
    base = {s: {"psnr": 30.0, "psnr_flare": 20.0, "ssim": 0.95, "held": 17.0, "held_ssim": 0.5}
            for s in "xyz"}

    def cand(**by_scene):
        return {s: {**base[s], **by_scene.get(s, {})} for s in base}

    up = {s: {"psnr_flare": 20.06} for s in "xyz"}
    assert m.photo_rule(cand(**up), base, "depth")["decision"] == "passes"
    one_down = {"x": {"psnr_flare": 20.4}, "y": {"psnr_flare": 19.94}, "z": {}}
    got = m.photo_rule(cand(**one_down), base, "depth")
    assert got["mean"]["psnr_flare"] > 0.05 and got["decision"] == "fails (a)"
    ssim = {**up, "x": {"psnr_flare": 20.06, "ssim": 0.947}}
    assert m.photo_rule(cand(**ssim), base, "depth")["decision"] == "fails (a)"
    blur = {s: {"psnr_flare": 20.06, "held_ssim": 0.497} for s in "xyz"}
    assert m.photo_rule(cand(**blur), base, "depth")["decision"] == "fails (b)"
    assert m.main(["rerender", str(tmp_path / "sceaux_synth"), "--from-arm", "b", "--arm", "c",
                   "--work", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "sceaux_b_s0.ws: no fine-tuned arm workspace" in err and len(err.splitlines()) == 1


def test_fmg_photo_ab_judges_the_committed_runs_and_names_a_missing_one(tmp_path, capsys):
    """`judge` on the twenty-third session's committed results gives fmg.md's table (L
    minus the shipped file, et's flare region -0.31 dB: fails (b)); with --baseline-seeds
    each arm is averaged over its own seeds; a missing arm or a bad seed list is one line,
    exit 2."""
    m = _photo_ab()
    results = Path(__file__).parents[2] / "docs" / "results"
    res = m.judge(results, "s23_L", "s23_shipped", ["sceaux", "et", "lund"], [0, 1])
    assert res["decision"] == "fails (b)"
    assert res["per_scene"]["et"]["psnr_flare"] == pytest.approx(-0.314, abs=1e-3)
    assert res["mean"]["psnr_flare"] == pytest.approx(0.182, abs=1e-3)
    # part (d) like for like: sceaux_castle's novel views against the shipped arm without
    # the target M's masks withhold (docs/history/fmg.md, "Twenty-fourth session": M -0.15 dB there)
    fair = m.judge(results, "s24_M", "s23_shipped", ["sceaux", "et", "lund"], [0, 1],
                   {"sceaux": "s24_shipped_no7102"})
    plain = m.judge(results, "s24_M", "s23_shipped", ["sceaux", "et", "lund"], [0, 1])
    assert fair["per_scene"]["sceaux"]["held"] == pytest.approx(-0.15, abs=0.01)
    assert plain["per_scene"]["sceaux"]["held"] == pytest.approx(-0.69, abs=0.01)
    assert fair["per_scene"]["lund"] == plain["per_scene"]["lund"]
    assert fair["per_scene"]["sceaux"]["psnr_flare"] == plain["per_scene"]["sceaux"]["psnr_flare"]
    assert m.main(["judge", str(tmp_path), "--candidate", "a", "--baseline", "b"]) == 2
    err = capsys.readouterr().err
    assert "fmg_a_fair_sceaux_s0.json: no such result" in err and len(err.splitlines()) == 1
    # each arm averaged over its own seeds (M′, twenty-sixth session: three seeds against
    # the shipped arm's two)
    three = m.judge(results, "s26_Mp", "s23_shipped", ["sceaux", "et", "lund"], [0, 1, 2],
                    baseline_seeds=[0, 1])
    for scene in ("sceaux", "et", "lund"):
        runs = {arm: [json.loads((results / m.result_name(arm, scene, s)).read_text())
                      for s in seeds] for arm, seeds in (("s26_Mp", (0, 1, 2)),
                                                         ("s23_shipped", (0, 1)))}
        want = (np.mean([r["heldout"]["psnr"] for r in runs["s26_Mp"]])
                - np.mean([r["heldout"]["psnr"] for r in runs["s23_shipped"]]))
        assert three["per_scene"][scene]["held"] == pytest.approx(want)
    assert three["baseline_seeds"] == [0, 1]
    assert m.main(["judge", str(results), "--candidate", "s26_Mp", "--baseline", "s23_shipped",
                   "--baseline-seeds", "0;1"]) == 2
    err = capsys.readouterr().err
    assert "--baseline-seeds takes seeds" in err and len(err.splitlines()) == 1


def test_fmg_photo_ab_joins_one_settings_runs_under_two_names(tmp_path, capsys):
    """An arm given as NAME:SEEDS+OTHER:SEEDS is averaged over both names' runs (one setting
    run again under a new name on new seeds); the plain name keeps --seeds; a bad seed in a
    joined arm is one line naming it, exit 2."""
    m = _photo_ab()
    results = Path(__file__).parents[2] / "docs" / "results"
    assert m.arm_runs("a", [2, 3]) == [("a", 2), ("a", 3)]
    assert m.arm_runs("a:2,3+b:4", [0]) == [("a", 2), ("a", 3), ("b", 4)]
    scenes = ["sceaux", "et", "lund"]
    for scene in scenes:  # the same runs under a second name, in a scratch folder
        for seed in (0, 1, 2):
            src = results / m.result_name("s26_Mp", scene, seed)
            name = m.result_name("s26_Mp" if seed < 2 else "again", scene, seed)
            (tmp_path / name).write_text(src.read_text())
        (tmp_path / m.result_name("s23_shipped", scene, 0)).write_text(
            (results / m.result_name("s23_shipped", scene, 0)).read_text())
    joined = m.judge(tmp_path, "s26_Mp:0,1+again:2", "s23_shipped", scenes, [0])
    whole = m.judge(results, "s26_Mp", "s23_shipped", scenes, [0, 1, 2], baseline_seeds=[0])
    assert joined["per_scene"] == whole["per_scene"]
    assert joined["seeds"] == [0, 1, 2] and joined["baseline_seeds"] == [0]
    assert joined["runs"]["candidate"] == [["s26_Mp", 0], ["s26_Mp", 1], ["again", 2]]
    one = m.judge(tmp_path, "s26_Mp:0", "s23_shipped", scenes, [0])
    assert one["per_scene"] != joined["per_scene"]
    assert m.main(["judge", str(tmp_path), "--candidate", "s26_Mp:0,x", "--baseline",
                   "s23_shipped", "--seeds", "0"]) == 2
    err = capsys.readouterr().err
    assert "arm 's26_Mp:0,x' takes seeds" in err and len(err.splitlines()) == 1


def test_fmg_photo_ab_judge_names_the_machines_and_warns_when_they_differ(tmp_path, capsys):
    """A judgement lists the machines its runs were made on (every committed one so far: a
    single machine); runs of two machines are judged as before, listed under each, and the
    command line warns on stderr."""
    m = _photo_ab()
    results = Path(__file__).parents[2] / "docs" / "results"
    scenes = ["sceaux", "et", "lund"]
    one = m.judge(results, "s78_F26fh", "s77_M", scenes, [2, 3])
    assert len(one["machines"]) == 1
    (runs,) = one["machines"].values()
    assert len(runs) == 12 and "fmg_s77_M_fair_et_s2.json" in runs
    for scene in scenes:
        for arm in ("s78_F26fh", "s77_M"):
            for seed in (2, 3):
                r = json.loads((results / m.result_name(arm, scene, seed)).read_text())
                if arm == "s78_F26fh" and seed == 3:
                    r["machine"] = {**r["machine"], "platform": "another-host"}
                (tmp_path / m.result_name(arm, scene, seed)).write_text(json.dumps(r))
    two = m.judge(tmp_path, "s78_F26fh", "s77_M", scenes, [2, 3])
    assert two["per_scene"] == one["per_scene"] and two["decision"] == one["decision"]
    other = [k for k in two["machines"] if "another-host" in k]
    assert len(two["machines"]) == 2 and len(other) == 1
    assert sorted(two["machines"][other[0]]) == sorted(
        m.result_name("s78_F26fh", s, 3) for s in scenes)
    assert m.main(["judge", str(tmp_path), "--candidate", "s78_F26fh", "--baseline", "s77_M",
                   "--seeds", "2,3"]) == 0
    err = capsys.readouterr().err
    assert "2 machines" in err and "3 runs" in err and "run both arms on one machine" in err
    assert m.main(["judge", str(results), "--candidate", "s78_F26fh", "--baseline", "s77_M",
                   "--seeds", "2,3"]) == 0
    assert "machines" not in capsys.readouterr().err
    # `machines` judges every saved judgement of a folder again: the mixed one is named
    saved = tmp_path / "saved"
    saved.mkdir()
    for f in tmp_path.glob("fmg_*_fair_*.json"):
        (saved / f.name).write_text(f.read_text())
    (saved / "two_judge.json").write_text(json.dumps({**two, "machines": {}}))
    (saved / "gone_judge.json").write_text(json.dumps({**two, "candidate": "gone"}))
    res = m.saved_machines(saved)
    assert res["mixed"] == ["two_judge.json"] and list(res["skipped"]) == ["gone_judge.json"]
    assert m.main(["machines", str(saved)]) == 1
    assert "more than one machine: two_judge.json" in capsys.readouterr().out
    assert m.main(["machines", str(tmp_path / "nope")]) == 2
    err = capsys.readouterr().err
    assert "nope: no such folder" in err and len(err.splitlines()) == 1


def test_fmg_photo_ab_spread_is_the_seed_to_seed_deviation(tmp_path, capsys):
    """`spread` on a committed arm of three seeds: each scene's standard deviation of each
    measure over the runs (n - 1), and the standard error of two such arms' mean
    difference; one run, or a missing one, is one line, exit 2."""
    m = _photo_ab()
    results = Path(__file__).parents[2] / "docs" / "results"
    scenes = ["sceaux", "et", "lund"]
    res = m.spread(results, "s29_frc", scenes, [2, 3, 4])
    sds = {}
    for scene in scenes:
        runs = [json.loads((results / m.result_name("s29_frc", scene, s)).read_text())
                for s in (2, 3, 4)]
        flare = [r["inputs"]["psnr_flare"] for r in runs]
        held = [r["heldout"]["psnr"] for r in runs]
        got = res["per_scene"][scene]
        assert got["psnr_flare"]["sd"] == pytest.approx(np.std(flare, ddof=1))
        assert got["held"]["mean"] == pytest.approx(np.mean(held))
        sds[scene] = np.std(flare, ddof=1)
    want = np.sqrt(sum(2 * v ** 2 / 4 for v in sds.values())) / 3
    assert res["se_mean_difference"]["4"]["psnr_flare"] == pytest.approx(want)
    assert res["se_mean_difference"]["2"]["psnr_flare"] == pytest.approx(want * np.sqrt(2))
    assert m.main(["spread", str(results), "--arm", "s29_frc", "--seeds", "2"]) == 2
    assert "two or more runs" in capsys.readouterr().err
    assert m.main(["spread", str(tmp_path), "--arm", "s29_frc", "--seeds", "2,3"]) == 2
    err = capsys.readouterr().err
    assert "fmg_s29_frc_fair_sceaux_s2.json: no such result" in err
    assert len(err.splitlines()) == 1


def test_network_scale_judge_video_part(tmp_path):
    """network_scale_ab's part (e): with the video's times, an arm whose camera-path frames
    take more than twice the base's fails there even when its held-out renders are cheap;
    without them the verdict has no part (e) (the committed judgements stay as they were)."""
    ab = load_benchmark("network_scale_ab")
    for arm, gain in (("base", 0.0), ("x", 0.3)):
        for sc in ("a", "b"):
            (tmp_path / f"p{arm}_{sc}_s1.json").write_text(json.dumps(
                {"heldout": {"psnr": 20.0 + gain, "ssim": 0.6}}))
    times = {(sc, 1, arm): 10.0 for sc in ("a", "b") for arm in ("base", "x")}
    plain = ab.judge(tmp_path, times, ["a", "b"], [1], ["x"], "p", "base")
    assert plain["candidates"]["x"]["decision"] == "passes"
    assert "e" not in plain["candidates"]["x"]["parts"]
    video = {("a", 1, "base"): 30.0, ("b", 1, "base"): 30.0,
             ("a", 1, "x"): 50.0, ("b", 1, "x"): 75.0}
    slow = ab.judge(tmp_path, times, ["a", "b"], [1], ["x"], "p", "base", video)
    assert slow["candidates"]["x"]["video_time_factor"] == pytest.approx(125 / 60)
    assert slow["candidates"]["x"]["decision"] == "fails (e)"
    assert slow["decision"] == "nothing changes"
    video[("b", 1, "x")] = 60.0
    ok = ab.judge(tmp_path, times, ["a", "b"], [1], ["x"], "p", "base", video)
    assert ok["candidates"]["x"]["decision"] == "passes" and ok["decision"] == "x"
    from pipeline.errors import UserError

    del video[("b", 1, "x")]  # one scene's line missing: named, not summed without it
    with pytest.raises(UserError, match="video times file has no line for .'b', 'any seed'"):
        ab.judge(tmp_path, times, ["a", "b"], [1], ["x"], "p", "base", video)


def test_novel_loo_table_reads_arms_and_names_a_missing_file(tmp_path, capsys):
    """novel_loo_table.py: arms found by their files, differences from the base as seed means
    then scene means; a missing draw or bad seeds are one line and exit 2."""
    tab = load_benchmark("novel_loo_table")
    for arm, (p, s) in (("base", (20.0, 0.5)), ("x", (20.5, 0.52))):
        for sc in ("a", "b"):
            for seed, bump in ((6, 0.0), (7, 0.2)):
                (tmp_path / f"{arm}_{sc}_s{seed}.json").write_text(json.dumps(
                    {"psnr": p + bump + (0.1 if sc == "b" and arm == "x" else 0.0),
                     "ssim": s, "sets": [] if arm == "base" else ["render.agree_window=3"]}))
    res = tab.table(tmp_path, "base", ["a", "b"], [6, 7])
    assert set(res) == {"base", "x"} and res["x"]["sets"] == ["render.agree_window=3"]
    assert res["x"]["scenes"]["a"] == pytest.approx([0.5, 0.02])
    assert res["x"]["scenes"]["b"] == pytest.approx([0.6, 0.02])
    assert res["x"]["mean"] == pytest.approx([0.55, 0.02])
    (tmp_path / "x_b_s7.json").unlink()
    assert tab.main([str(tmp_path), "--scenes", "a,b", "--arms", "x"]) == 2
    assert capsys.readouterr().err.strip().endswith(
        "x_b_s7.json: no such result; render it with novel_loo.py first")
    assert tab.main([str(tmp_path), "--seeds", "six"]) == 2
    assert "--seeds takes integers" in capsys.readouterr().err


def test_keys_rule_asks_the_frames_at_the_photos_and_holds_the_held_out_views():
    """``--rule keys``: +0.25 dB at the photos' cameras everywhere passes; a mean gain with
    one scene -0.06 fails (a); their flare region -0.11 on the mean fails (b); held-out -0.21
    on one scene fails (c). ``keys-guard`` asks no gain, only that nothing falls."""
    m = _photo_ab()
    base = {s: {"psnr": 30.0, "psnr_flare": 20.0, "ssim": 0.95, "held": 17.0, "keys": 20.0,
                "keys_flare": 15.0} for s in "xyz"}

    def cand(**by_scene):
        return {s: {**base[s], **by_scene.get(s, {})} for s in base}

    up = {s: {"keys": 20.25} for s in "xyz"}
    assert m.photo_rule(cand(**up), base, "keys")["decision"] == "passes"
    assert m.photo_rule(cand(), base, "keys")["decision"] == "fails (a)"
    assert m.photo_rule(cand(x={"keys": 19.94}, y={"keys": 21.0}, z={"keys": 21.0}), base,
                        "keys")["decision"] == "fails (a)"
    down = {s: {"keys": 20.25, "keys_flare": 14.89} for s in "xyz"}
    assert m.photo_rule(cand(**down), base, "keys")["decision"] == "fails (b)"
    held = {**up, "x": {"keys": 20.25, "held": 16.79}}
    assert m.photo_rule(cand(**held), base, "keys")["decision"] == "fails (c)"
    assert m.photo_rule(cand(), base, "keys-guard")["decision"] == "passes"
    assert m.photo_rule(cand(**{s: {"keys": 19.94} for s in "xyz"}), base,
                        "keys-guard")["decision"] == "fails (a)"


def test_reach_rule_asks_the_held_out_views_and_holds_the_rest():
    """``--rule reach``: held-out +0.06 dB everywhere passes; +0.04 fails (a), so does a mean
    gain with one scene -0.11; held-out SSIM -0.003 fails (b); the frames at the photos'
    cameras -0.06 fails (c), their flare region -0.11 too. ``reach-guard`` asks no gain: a
    held-out mean -0.04 passes, -0.06 fails (a)."""
    m = _photo_ab()
    base = {s: {"psnr": 30.0, "psnr_flare": 20.0, "ssim": 0.95, "held": 17.0,
                "held_ssim": 0.6, "keys": 20.0, "keys_flare": 15.0} for s in "xyz"}

    def cand(held: float, **more):
        return {s: {**base[s], "held": 17.0 + held, **more.get(s, {})} for s in base}

    assert m.photo_rule(cand(0.06), base, "reach")["decision"] == "passes"
    assert m.photo_rule(cand(0.04), base, "reach")["decision"] == "fails (a)"
    assert m.photo_rule(cand(0.3, x={"held": 16.89}), base, "reach")["decision"] == "fails (a)"
    low_ssim = {s: {"held_ssim": 0.597} for s in "xyz"}
    assert m.photo_rule(cand(0.06, **low_ssim), base, "reach")["decision"] == "fails (b)"
    for k, v in (("keys", 19.94), ("keys_flare", 14.89)):
        worse = {s: {k: v} for s in "xyz"}
        assert m.photo_rule(cand(0.06, **worse), base, "reach")["decision"] == "fails (c)"
    assert m.photo_rule(cand(-0.04), base, "reach-guard")["decision"] == "passes"
    assert m.photo_rule(cand(-0.06), base, "reach-guard")["decision"] == "fails (a)"
    assert m.photo_rule(cand(0.0, x={"held": 16.79}), base,
                        "reach-guard")["decision"] == "fails (a)"


def _mixed_arm(folder, psnr: dict, seconds: float):
    """One arm's files as benchmarks/mixed_sizes_judge.py reads them."""
    folder.mkdir(parents=True)
    for part in ("heldout", "non_targets"):
        views = {k: {"psnr": v, "ssim": 0.5} for k, v in psnr.items() if k.startswith(part[0])}
        (folder / f"{part}.json").write_text(json.dumps({"per_view": views}))
    (folder / "finetune_seconds").write_text(str(seconds))


def test_mixed_sizes_judge_averages_seeds_before_its_rule(tmp_path):
    """benchmarks/mixed_sizes_judge.py --seeds: each scene's PSNR is the mean of its seeds'
    means, so one seed's loss past 0.2 dB that another seed makes up passes (b), while a loss
    that holds over the seeds fails it; time sums over scenes and seeds; arms that scored
    different frames are refused."""
    bench = load_benchmark("mixed_sizes_judge")
    base = {"h1": 17.0, "n1": 16.0}
    deltas = {("a", 2): 0.1, ("a", 3): 0.1, ("b", 2): -0.5, ("b", 3): 0.3}
    for (scene, seed), d in deltas.items():
        _mixed_arm(tmp_path / f"seed{seed}" / scene / "baseline", base, 100.0)
        _mixed_arm(tmp_path / f"seed{seed}" / scene / "candidate",
                   {k: v + d for k, v in base.items()}, 110.0 + seed)
    v = bench.judge(tmp_path, ["a", "b"], [2, 3])
    assert v["scenes"]["b"]["delta"] == pytest.approx(-0.1)
    assert v["worst_scene_delta"] == pytest.approx(-0.1) and v["passed"]
    assert v["finetune_seconds"]["candidate"] == pytest.approx(2 * 112 + 2 * 113)
    assert bench.judge(tmp_path, ["b"], [2])["rule"]["b_each_scene"] is False
    assert bench.judge(tmp_path, ["a", "b"], [2, 3], time_ratio=1.1)["rule"]["c_time"] is False
    untimed = bench.judge(tmp_path, ["a", "b"], [2, 3], time_ratio=0)
    assert "c_time" not in untimed["rule"] and untimed["passed"]
    assert untimed["time_ratio"] == pytest.approx(v["time_ratio"])
    # a limit below 1 (a change for speed): 112.5 s on the mean against 100 fails 0.97
    assert v["rule"]["c_time"] and not bench.judge(tmp_path, ["a", "b"], [2, 3],
                                                   time_ratio=0.97)["rule"]["c_time"]
    (tmp_path / "seed3" / "b" / "candidate" / "heldout.json").write_text(
        json.dumps({"per_view": {"h2": {"psnr": 17.0, "ssim": 0.5}}}))
    with pytest.raises(SystemExit, match="b: the arms scored different frames"):
        bench.judge(tmp_path, ["a", "b"], [2, 3])


def test_unseen_judge_pools_seeds_and_applies_its_tolerances(tmp_path):
    """benchmarks/unseen_judge.py: per seed the frames' PSNR averaged, then the seeds; the
    region where the arms differ by more than ``level`` pooled over every seed; the rule's
    per-scene and SSIM tolerances."""
    judge = load_benchmark("unseen_judge")
    rng = np.random.default_rng(0)
    scenes = []
    for k in range(3):
        scene = tmp_path / f"x{k}_synth"
        (scene / "clean").mkdir(parents=True)
        gt = rng.integers(40, 200, (24, 32, 3)).astype(np.uint8)
        cv2.imwrite(str(scene / "clean" / "v.png"), gt)
        for arm, err in (("base", 12), ("cand", 6 if k < 2 else 14)):
            for s in (5, 6):
                d = tmp_path / "J" / scene.name / arm / f"s{s}" / "loo"
                d.mkdir(parents=True)
                img = gt.astype(int)
                img[:8] += err  # the arms differ in the top rows only
                img[8:] += 1 if arm == "cand" else 0  # by one level below: not region at 1
                cv2.imwrite(str(d / "v.png"), np.clip(img, 0, 255).astype(np.uint8))
        scenes.append(str(scene))
    out = tmp_path / "j.json"
    judge.main([str(tmp_path / "J"), "--scenes", ",".join(scenes), "--baseline", "base",
                "--candidate", "cand", "--seeds", "5,6", "--level", "1",
                "--scene-tolerance", "0.05", "--ssim-tolerance", "0.001", "--out", str(out)])
    rec = json.loads(out.read_text())
    x0 = rec["scenes"]["x0_synth"]
    assert x0["frames"] == 2 and abs(x0["region_share"] - 8 / 24) < 1e-9
    assert x0["region"]["candidate"] > x0["region"]["baseline"]
    assert len(x0["whole_per_seed"]["baseline"]) == 2
    r = rec["rule"]
    assert r["region_gains"][2] < 0 < r["region_gains"][0]  # two of three up
    assert r["a"] is True
    worst = min(s["whole"]["candidate"] - s["whole"]["baseline"] for s in rec["scenes"].values())
    assert worst < -0.05 and r["b"] is False and r["passed"] is False  # x2 fell too far
    assert "ssim_gain_mean" in r and isinstance(r["c"], bool)



def test_path_zoom_warps_a_frame_into_its_photo_and_judges_the_zoomed_photos(tmp_path, capsys):
    """path_zoom.py: a frame seen from the photo's centre lands on the photo's pixels by the
    two intrinsics (a frame twice as wide shows the photo at half the pixels: lower PSNR);
    the gain fit forgives an exposure; the rule asks every zoomed-in photo and the mean."""
    pz = load_benchmark("path_zoom")
    rng = np.random.default_rng(0)
    photo = cv2.GaussianBlur(rng.random((48, 64, 3)).astype(np.float32), (0, 0), 1.0)
    K = np.array([[60.0, 0, 32], [0, 60.0, 24], [0, 0, 1]])
    back, seen = pz.to_photo(photo, K, K, (64, 48))  # the same camera: the photo itself
    assert seen.all() and np.abs(back - photo)[2:-2, 2:-2].max() < 1e-5
    wide = K.copy()
    wide[:2, :2] /= 2  # half the focal length: the photo fills the frame's middle quarter
    frame = cv2.resize(photo, (32, 24), interpolation=cv2.INTER_AREA)
    big = np.zeros((48, 64, 3), np.float32)
    big[12:36, 16:48] = frame
    got, seen = pz.to_photo(big, wide, K, (64, 48))
    assert seen.all()
    assert pz.gain_psnr(back, photo, seen) > pz.gain_psnr(got, photo, seen) + 3
    assert pz.gain_psnr(0.5 * photo, photo, seen) > 60  # an exposure is forgiven
    _, seen = pz.to_photo(photo, K, wide, (64, 48))  # a wider photo: only its middle
    assert 0.2 < seen.mean() < 0.3

    def row(zoom, fixed, photos):
        return {"zoom": zoom, "fixed": {"psnr": fixed}, "photos": {"psnr": photos}}

    ok = [row(1.0, 30.0, 30.0), row(2.0, 20.0, 22.0), row(3.0, 18.0, 19.5)]
    assert pz.judge(ok, 1.25)["passed"]
    assert pz.judge(ok, 1.25)["zoomed_mean_gain_db"] == pytest.approx(1.75)
    assert not pz.judge(ok[:2] + [row(3.0, 18.0, 17.9)], 1.25)["passed"]  # every one
    assert not pz.judge([row(1.0, 30, 30), row(2.0, 20, 20.5)], 1.25)["passed"]  # 1 dB
    assert not pz.judge([row(1.0, 30, 29.8)] + ok[1:], 1.25)["passed"]  # the others held
    assert not pz.judge([row(1.0, 30, 30)], 1.25)["passed"]  # nothing zoomed: no verdict
    tiles = [[photo] * 3, [photo[:, :24]] * 3]  # a landscape photo and a portrait one
    scored = [{"zoom": z, "fixed": {"psnr": 20.0}, "photos": {"psnr": 25.0}} for z in (1, 2)]
    pz.write_sheet(tmp_path / "sheet.jpg", tiles, scored)
    sheet = cv2.imread(str(tmp_path / "sheet.jpg"))
    assert sheet.shape == (2 * 240, 3 * 320, 3)  # a row a photo, padded to the widest
    assert sheet[240:, 3 * 120 + 16:].mean() < 2 < sheet[240:, :3 * 120 - 16].mean()  # padding
    assert pz.main([str(tmp_path)]) == 2
    assert "no cameras.json" in capsys.readouterr().err
    (tmp_path / "cameras.json").write_text("{}")  # posed by hand, nothing else: one line
    assert pz.main([str(tmp_path)]) == 2
    assert capsys.readouterr().err.startswith("error: ")


def test_frames_sheet_rows_every_nth_frame_and_names_an_empty_folder(tmp_path, capsys):
    """frames_sheet.py: a row per folder of every N-th frame at one height (rows padded to
    one width); a folder without frames is one line naming it."""
    fs = load_benchmark("frames_sheet")
    for name, n, shape in (("a", 9, (30, 40, 3)), ("b", 5, (30, 60, 3))):
        (tmp_path / name).mkdir()
        for i in range(n):
            cv2.imwrite(str(tmp_path / name / f"{i:05d}.png"), np.full(shape, 20 * i, np.uint8))
    rows = fs.sheet_rows([(tmp_path / "a", "fixed"), (tmp_path / "b", "")], every=4, height=60)
    assert [r.shape for r in rows] == [(60, 240, 3), (60, 240, 3)]  # 3 cells of 80, 2 of 120
    assert np.median(rows[0][:, 80:160, 0]) == 80  # frame 4, under its label
    assert np.median(rows[0][:, 160:, 0]) == 160  # frame 8
    assert (rows[1][:, 120:, 0] == 80).mean() > 0.5  # the second row: frames 0 and 4
    assert fs.main([str(tmp_path / "a"), "--out", str(tmp_path / "s.jpg")]) == 0
    assert cv2.imread(str(tmp_path / "s.jpg")).shape[:2] == (160, 3 * 213)
    (tmp_path / "empty").mkdir()
    with pytest.raises(SystemExit, match="empty: no frames"):
        fs.main([str(tmp_path / "empty"), "--out", str(tmp_path / "t.jpg")])


def test_fmg_photo_ab_keys_path_is_the_training_cameras_written_once(tmp_path):
    """fmg_photo_ab.py --keys: WS/eval/input_cameras.json holds one frame at each training
    photo's camera of the synth scene (the shipped sample's truth), in split order, with that
    camera's intrinsics, pose and size; a second call keeps the file as it is."""
    from gnfr.paths import path_from_json
    from workflows.research.eval.scene import load_synth

    bench = load_benchmark("fmg_photo_ab")
    synth = Path(__file__).resolve().parents[2] / "samples" / "cyprus_truth"
    path = bench.keys_path_json(synth, tmp_path)
    assert path == tmp_path / "eval" / "input_cameras.json"
    scene = load_synth(synth)
    cams = path_from_json(json.loads(path.read_text()))
    assert [c.name for c in cams] == scene.train and len(cams) == 8
    by_stem = scene.cams.by_stem()
    for c in cams:
        f = by_stem[c.name]
        assert np.allclose(c.K, f.K) and np.allclose(c.c2w, f.c2w)
        assert (c.width, c.height) == (f.width, f.height)
    path.write_text(path.read_text().replace("\n", " ") + " ")
    kept = path.read_text()
    assert bench.keys_path_json(synth, tmp_path).read_text() == kept
