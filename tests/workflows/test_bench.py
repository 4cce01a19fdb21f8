"""`deflare-scene bench --quick` (the JSON record has every measurement, all positive) and the
benchmarks' shell helper for the lent GPU (`benchmarks/device_slim.sh`)."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest
import torch

from workflows.cli import main
from workflows.research.bench import PeakMemory, synthetic_scene


def test_bench_quick_writes_json(tmp_path, one_torch_thread):
    out = tmp_path / "bench.json"
    assert main(["bench", "--quick", "--device", "cpu", "--out", str(out)]) == 0
    rec = json.loads(out.read_text())
    m = rec["machine"]
    assert m["cores"] >= 1 and m["torch"] == torch.__version__ and m["cpu"]
    assert rec["settings"]["quick"] and rec["preset"]["name"] == "quick"
    assert list(rec["results"]) == ["cpu"]
    r = rec["results"]["cpu"]
    assert set(r["train"]) == {"end_to_end", "cached", "reference", "processes"}
    for mode in r["train"].values():
        assert mode["it_per_s"] > 0 and mode["steps"] == 2 and "peak_mib" in mode
    assert r["train"]["processes"]["processes"] == 2  # the fine-tune's split, 1 thread each
    from gnfr.renderer import cpu_bf16

    default = cpu_bf16(None, "cpu")  # the fast paths run the stages' default, recorded
    assert r["train"]["reference"]["cpu_bf16"] is False
    assert all(r["train"][m]["cpu_bf16"] is default for m in ("end_to_end", "cached"))
    assert all(rr["cpu_bf16"] is default for rr in r["render"].values())
    assert set(r["render"]) == {"504x378", "1008x756"}
    for rr in r["render"].values():
        assert rr["rays_timed"] == 128 and rr["samples"] == 8
        for path in ("fast", "reference"):
            assert rr[path]["s_per_frame"] > 0 and rr[path]["ms_per_ray"] > 0
        # the reference re-encodes its sources for the frame: that time is in its frame
        assert rr["reference"]["s_per_frame"] >= rr["reference"]["encode_per_frame_s"] > 0
    assert "cpu" in rec["memory_method"]
    from pipeline.provenance import code_version

    assert rec["code"] == json.loads(json.dumps(code_version())) and rec["command"]


def test_bench_rejects_unknown_device(tmp_path):
    assert main(["bench", "--quick", "--device", "tpu", "--out", str(tmp_path / "b.json")]) == 2
    assert not (tmp_path / "b.json").exists()


def test_peak_memory_sees_an_allocation():
    with PeakMemory("cpu") as mem:
        x = torch.ones(64, 2**20)   # 64 Mi float32 = 256 MiB
        x += 1
        del x
    assert mem.mib > 100, mem.how


def test_synthetic_scene_shapes():
    s = synthetic_scene(6, (64, 48))
    assert s.images.shape == (6, 3, 48, 64) and s.masks.shape == (6, 1, 48, 64)
    assert s.flare["v00"] > 0 and s.flare["v01"] == 0
    assert s.ranked["v00"][0] == "v01"


def test_measure_in_a_fresh_process():
    """Isolated CPU measurements run in a spawned process and return the same record."""
    from gnfr.train import PRESETS
    from workflows.research.bench import BenchConfig, bench_train, effective, measure

    cfg = effective(BenchConfig(quick=True))
    scene = synthetic_scene(5, (64, 48))
    rec = measure(True, bench_train, cfg, PRESETS["tiny"], scene, "cpu", "cached")
    assert rec["it_per_s"] > 0 and rec["steps"] == 2 and "peak_mib" in rec


def test_peak_memory_sees_an_allocation_and_its_release():
    """The CPU peak is what was allocated inside the block (above the start), not 0."""
    import time

    import numpy as np

    from workflows.research.bench import PeakMemory

    with PeakMemory("cpu") as mem:
        a = np.ones(200 * 2**20 // 8)  # 200 MiB, touched
        time.sleep(0.05)
        del a
    assert 150 < mem.mib < 400, mem.mib
    with PeakMemory("cpu") as small:
        time.sleep(0.02)
    assert small.mib < 50


def _snapshot(root):
    """{relative path: bytes} of every file under ``root``."""
    return {p.relative_to(root): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def test_bench_workspace_times_both_fills_and_leaves_the_workspace_as_it_was(
        tmp_path, one_torch_thread):
    """--workspace: GN-FR alone and the hybrid fill, each width, rendered by the stage in a
    scratch workspace; the user's workspace is byte-for-byte unchanged and has no renders."""
    from pipeline.depth import DepthConfig
    from pipeline.depth import run as depth_run
    from tests.fixtures import make_plane_workspace
    from tests.pipeline.render_ws import add_masks_views_model
    ws = make_plane_workspace(tmp_path / "ws")
    add_masks_views_model(ws, "plane02", (slice(40, 70), slice(60, 100)), 0)
    depth_run(DepthConfig(neighbours=3), ws)
    before = _snapshot(ws.root)
    out = tmp_path / "bench.json"
    assert main(["bench", "--quick", "--device", "cpu", "--workspace", str(ws.root),
                 "--out", str(out)]) == 0
    assert _snapshot(ws.root) == before and not ws.renders.exists()
    rec = json.loads(out.read_text())["results"]["cpu"]["render_workspace"]
    assert rec["frames"] == 1 and rec["workspace"] == str(ws.root)
    got = {(tuple(r["size"]), r["fill"]): r["s_per_frame"] for r in rec["rows"]}
    # 160x120 photos: the path's aspect is kept at each width
    assert set(got) == {((w, h), f) for w, h in ((48, 36), (96, 72))
                        for f in ("network", "hybrid")}
    assert all(v > 0 for v in got.values())


def test_bench_workspace_without_depth_is_one_line_and_exit_2(tmp_path, capsys):
    from tests.fixtures import make_plane_workspace
    from tests.pipeline.render_ws import add_masks_views_model

    ws = make_plane_workspace(tmp_path / "ws")
    add_masks_views_model(ws, "plane02", (slice(40, 70), slice(60, 100)), 0)
    out = tmp_path / "b.json"
    assert main(["bench", "--quick", "--workspace", str(ws.root), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(ws.depth) in err[0] and "deflare-scene depth" in err[0]
    assert not out.exists()


def test_bench_fill_only_times_the_workspace_frames_alone(tmp_path, one_torch_thread):
    """--fill-only: the workspace's frame rows, no synthetic training or render rows; without
    --workspace one line and exit 2."""
    from pipeline.depth import DepthConfig
    from pipeline.depth import run as depth_run
    from tests.fixtures import make_plane_workspace
    from tests.pipeline.render_ws import add_masks_views_model
    ws = make_plane_workspace(tmp_path / "ws")
    add_masks_views_model(ws, "plane02", (slice(40, 70), slice(60, 100)), 0)
    depth_run(DepthConfig(neighbours=3), ws)
    out = tmp_path / "bench.json"
    assert main(["bench", "--quick", "--fill-only", "--device", "cpu", "--workspace",
                 str(ws.root), "--out", str(out)]) == 0
    res = json.loads(out.read_text())["results"]["cpu"]
    assert res["train"] == {} and res["render"] == {}
    assert len(res["render_workspace"]["rows"]) == 4
    bad = tmp_path / "b.json"
    assert main(["bench", "--quick", "--fill-only", "--out", str(bad)]) == 2
    assert not bad.exists()


def test_device_slim_holds_and_restores_files_and_links(tmp_path):
    """benchmarks/device_slim.sh in a small git checkout: `out` holds a tracked file and a
    tracked symbolic link outside the checkout and says what would travel; `back` restores
    both (a link was left behind before the fortieth session) and the checkout is clean."""
    import shutil
    import subprocess

    if shutil.which("git") is None or shutil.which("bash") is None:
        pytest.skip("needs git and bash")
    repo = tmp_path / "repo"
    (repo / "benchmarks").mkdir(parents=True)
    shutil.copy(Path(__file__).resolve().parents[2] / "benchmarks" / "device_slim.sh",
                repo / "benchmarks")
    (repo / "samples" / "a").mkdir(parents=True)
    (repo / "samples" / "a" / "x.jpg").write_bytes(b"x" * 1000)
    (repo / "samples" / "b").mkdir()
    (repo / "samples" / "b" / "photos").symlink_to("../a")
    env = {"HELD": str(tmp_path / "held"), "PATH": "/usr/bin:/bin",
           "GIT_AUTHOR_NAME": "t", "GIT_AUTHOR_EMAIL": "t@t", "GIT_COMMITTER_NAME": "t",
           "GIT_COMMITTER_EMAIL": "t@t", "HOME": str(tmp_path)}

    def run(*cmd):
        return subprocess.run(cmd, cwd=repo, env=env, capture_output=True, text=True)

    for cmd in (("git", "init", "-q"), ("git", "add", "-A"), ("git", "commit", "-qm", "a")):
        assert run(*cmd).returncode == 0
    held = run("bash", "benchmarks/device_slim.sh", "out", "samples")
    assert held.returncode == 0 and "would travel" in held.stdout, held.stderr
    assert not (repo / "samples").exists()
    back = run("bash", "benchmarks/device_slim.sh", "back")
    assert back.returncode == 0 and "checkout whole again" in back.stdout, back.stderr
    assert (repo / "samples" / "b" / "photos").is_symlink()
    assert run("git", "status", "--short").stdout == ""


def test_build_flared_dev_scenes_names_the_missing_workspace(tmp_path):
    """benchmarks/build_flared_dev_scenes.sh without the posed development workspaces: one
    line naming the first missing one and what to run, exit 2, nothing written."""
    script = Path(__file__).resolve().parents[2] / "benchmarks" / "build_flared_dev_scenes.sh"
    out = subprocess.run(["bash", str(script), str(tmp_path)], capture_output=True, text=True)
    assert out.returncode == 2
    assert out.stderr.strip() == (f"no {tmp_path}/sceaux_ws: run "
                                  f"benchmarks/build_dev_scenes.sh {tmp_path} first")
    assert list(tmp_path.iterdir()) == []


def test_arm_frames_figure_labels_each_arm_with_its_psnr(tmp_path, capsys):
    """benchmarks/arm_frames.py: truth first, then each arm's held-out render labelled with
    its PSNR against the truth (scored as the eval scores it); a missing arm or a label
    count that does not match is one line, exit 2."""
    import cv2
    import numpy as np

    from pipeline import metrics
    from tests.conftest import load_benchmark

    m = load_benchmark("arm_frames")
    synth = tmp_path / "toy_synth"
    (synth / "clean").mkdir(parents=True)
    rng = np.random.default_rng(0)
    truth = rng.integers(0, 256, (40, 60, 3), dtype=np.uint8)
    cv2.imwrite(str(synth / "clean" / "v1.png"), truth)
    renders = {}
    for arm, noise in (("a", 10), ("b", 40)):
        d = tmp_path / "work" / f"toy_{arm}_s3.ws" / "renders" / "heldout_cameras"
        d.mkdir(parents=True)
        img = np.clip(truth.astype(int) + rng.integers(-noise, noise, truth.shape), 0, 255)
        renders[arm] = img.astype(np.uint8)
        cv2.imwrite(str(d / "v1.png"), renders[arm])
    out = tmp_path / "fig.jpg"
    assert m.main([str(synth), "v1", "--work", str(tmp_path / "work"), "--seed", "3",
                   "--arms", "a,b", "--height", "80", "--out", str(out)]) == 0
    fig = cv2.imread(str(out))
    assert fig.shape == (80, 3 * 120, 3)  # truth and two arms, each 120 px wide at 80 px
    labels = [f"{arm}: {metrics.psnr(renders[arm], truth):.2f} dB" for arm in "ab"]
    seen = []
    monkey = m.tile
    m.tile = lambda img, label, height: (seen.append(label), monkey(img, label, height))[1]
    m.figure(synth, "v1", tmp_path / "work", 3, ["a", "b"], ["a", "b"], 80)
    assert seen == ["truth v1", *labels]
    capsys.readouterr()
    assert m.main([str(synth), "v1", "--work", str(tmp_path / "work"), "--seed", "4",
                   "--arms", "a", "--out", str(tmp_path / "x.jpg")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "toy_a_s4.ws" in err[0] and "run the arm first" in err[0]
    assert m.main([str(synth), "v1", "--work", str(tmp_path / "work"), "--seed", "3",
                   "--arms", "a,b", "--labels", "one", "--out", str(tmp_path / "x.jpg")]) == 2
    assert not (tmp_path / "x.jpg").exists()


def test_refine_sim_aligns_exposure_starts_as_identity_and_learns(one_torch_thread):
    """benchmarks/refine_sim.py (the fifty-first session's exploration): a photo is brought
    to its render's exposure by one gain per channel on the clear pixels; an untrained
    refiner returns its input; a few dozen steps fit a scene-wide colour change on the clear
    pixels and ignore what the mask leaves out."""
    import numpy as np

    from pipeline.colour import linear_to_srgb, srgb_to_linear
    from tests.conftest import load_benchmark

    m = load_benchmark("refine_sim")
    rng = np.random.default_rng(0)
    render = rng.integers(40, 200, (32, 48, 3)).astype(np.uint8)
    lin = srgb_to_linear(render.astype(np.float32) / 255) / np.array([2.0, 1.5, 1.0])
    photo = np.clip(linear_to_srgb(lin) * 255 + 0.5, 0, 255).astype(np.uint8)
    clear = np.ones((32, 48), bool)
    back = m.align_exposure(photo, render, clear)
    assert np.abs(back.astype(int) - render).max() <= 2
    assert np.array_equal(m.align_exposure(photo, render, ~clear), photo)  # too few pixels

    net = m.refiner(8)
    x = m.to_tensor(render)
    with torch.no_grad():
        assert torch.equal(net(x), x)
    target = np.clip(render.astype(int) * 0.8, 0, 255).astype(np.uint8)
    weight = torch.ones(1, 1, 32, 48)
    weight[..., :, :24] = 0  # the left half is "flare": not in the loss
    poisoned = target.copy()
    poisoned[:, :24] = 255
    data = [(x, m.to_tensor(poisoned), weight)]
    net = m.train(data, iters=60, crop=24, width=8, seed=0)
    with torch.no_grad():
        out = m.to_bgr(net(x)).astype(float)
    before = np.abs(render.astype(float) - target).mean()
    after = np.abs(out - target).mean()
    assert after < 0.6 * before, (before, after)


def test_refine_cross_families_are_development_scenes_and_a_missing_arm_is_one_line(
        tmp_path, capsys):
    """benchmarks/refine_cross.py: each family is one development scene's three builds, two
    seeds each, and no test scene is among them; a missing arm or render folder is one line
    naming it, exit 2."""
    from pipeline.scene_splits import DEV_SCENES, FMG_DEV_SCENES, TEST_SCENES
    from tests.conftest import load_benchmark

    m = load_benchmark("refine_cross")
    assert sorted(m.FAMILIES) == ["et", "lund", "sceaux"]
    for fam, arms in m.FAMILIES.items():
        assert len(arms) == 6 and len({(a, s) for _, a, s in arms}) == 6
        assert all(scene.startswith(fam) for scene, _, _ in arms)
        assert not any(scene.startswith(t) for scene, _, _ in arms for t in TEST_SCENES)
    assert {"sceaux_castle", "et", "lund"} <= set(DEV_SCENES + FMG_DEV_SCENES)
    rc = m.main(["--test", "et", "--work", str(tmp_path / "w"), "--loo", str(tmp_path / "l"),
                 "--out", str(tmp_path / "o.json")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "is missing" in err[0] and str(tmp_path) in err[0]
    assert not (tmp_path / "o.json").exists()


def test_path_motion_scores_a_known_step_and_a_known_flow(tmp_path):
    """benchmarks/path_motion.py: a sideways step of 0.1 before a wall at depth 2 moves it
    f * 0.05 pixels (a share of the width); a picture shifted by 4 pixels between two frames
    has a median flow of 4 pixels; names of workspaces read as the files name them."""
    import cv2
    import numpy as np

    from tests.conftest import load_benchmark

    m = load_benchmark("path_motion")
    u = np.linspace(-3, 3, 31)
    x, y = np.meshgrid(u, u)
    wall = np.stack([x.ravel(), y.ravel(), np.full(x.size, 2.0)], -1)
    K = np.array([[100.0, 0, 64], [0, 100.0, 48], [0, 0, 1]])
    poses = np.tile(np.eye(4), (3, 1, 1))
    poses[1, 0, 3], poses[2, 0, 3] = 0.1, 0.3
    steps = m.step_motion(K, (128, 96), poses, wall)
    assert np.allclose(steps, [100 * 0.05 / 128, 100 * 0.1 / 128])
    s = m.summary(steps)
    assert s["max"] == steps.max() and s["max_over_median"] == steps.max() / np.median(steps)
    rng = np.random.default_rng(0)
    img = cv2.GaussianBlur(rng.integers(0, 255, (96, 140)).astype(np.uint8), (0, 0), 2)
    frames = tmp_path / "frames"
    frames.mkdir()
    for i, dx in enumerate((0, 4)):
        cv2.imwrite(str(frames / f"{i:05d}.png"), img[:, 8 - dx:8 - dx + 128])
    flow = m.frame_flow(frames)
    assert flow.shape == (1,) and abs(flow[0] * 128 - 4) < 0.5
    assert m.scene_name(tmp_path / "lund_synth" / "eval.ws") == "lund_synth"
    assert m.scene_name(tmp_path / "et_p5_s50_ag12_s22.ws") == "et_p5_s50_ag12_s22"


def test_path_motion_without_a_posed_workspace_is_one_line(tmp_path, capsys):
    """benchmarks/path_motion.py on a folder that is no posed workspace: one line, exit 2."""
    from tests.conftest import load_benchmark

    m = load_benchmark("path_motion")
    assert m.main([str(tmp_path / "nothing.ws")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error:") and "\n" not in err and "nothing.ws" in err


def _moving_frames(folder, shifts, gain_at=None, gain=1.0):
    """PNG frames of one blurred noise picture shifted sideways by ``shifts`` pixels; the frame
    ``gain_at`` brightened by ``gain`` (a pop); each with a little noise of its own."""
    import cv2
    import numpy as np

    rng = np.random.default_rng(1)
    img = cv2.GaussianBlur(rng.integers(0, 255, (96, 160, 3)).astype(np.uint8), (0, 0), 2)
    folder.mkdir()
    for i, dx in enumerate(shifts):
        f = img[:, 16 - dx:16 - dx + 128].astype(np.float32)
        if i == gain_at:
            f = f * gain
        f += rng.normal(0, 2, f.shape)
        cv2.imwrite(str(folder / f"{i:05d}.png"), np.clip(f, 0, 255).astype(np.uint8))


@pytest.mark.parametrize("flow", ["dis", "farneback"])
def test_video_flicker_finds_the_frame_that_pops(tmp_path, flow):
    """benchmarks/video_flicker.py: steady motion warps away (small error on most of the
    frame); a frame brightened by 30 % makes both its steps the largest, the spread
    follows, and a cameras.json's sources mark the steps where they change; by either
    flow."""
    import json

    from tests.conftest import load_benchmark

    m = load_benchmark("video_flicker")
    _moving_frames(tmp_path / "f", [0, 2, 4, 6, 8, 10], gain_at=3, gain=1.3)
    cams = {"frames": [{"sources": s} for s in
                       (["a", "b"], ["a", "b"], ["a", "b"], ["a", "c"], ["a", "c"], ["a", "c"])]}
    (tmp_path / "f" / "cameras.json").write_text(json.dumps(cams))
    r = m.path_flicker(tmp_path / "f", flow)
    err = [s["error"] for s in r["steps"]]
    assert r["frames"] == 6 and len(err) == 5
    assert min(s["compared"] for s in r["steps"]) > 0.5
    steady = [err[0], err[1], err[4]]
    assert max(steady) < 0.01 and min(err[2], err[3]) > 5 * max(steady)
    assert r["max"] == max(err) and r["spread"] == round(r["p90"] / r["median"], 4)
    assert [s["sources_changed"] for s in r["steps"]] == [False, False, True, False, False]
    assert r["changed_steps"] == 1 and r["changed_mean"] == err[2]
    assert r["sharpness"] > 0


def test_video_flicker_exposure_rule_sees_a_darker_video(tmp_path):
    """``--rule exposure``: a baseline that pops (one frame 30 % brighter, the next 30 %
    darker) against a candidate without the pops passes on the errors by both flows; the
    same candidate made two thirds of a stop darker everywhere fails on its brightness (a
    darker video has smaller errors); its sharpness at the baseline's exposure, reported,
    is the undarkened one's (a gain keeps it)."""
    import shutil

    import cv2
    import numpy as np

    from tests.conftest import load_benchmark

    m = load_benchmark("video_flicker")
    _moving_frames(tmp_path / "base", [0, 2, 4, 6, 8, 10], gain_at=3, gain=1.3)
    f = tmp_path / "base" / "00004.png"
    cv2.imwrite(str(f), (cv2.imread(str(f)).astype(np.float32) * 0.7).astype(np.uint8))
    _moving_frames(tmp_path / "calm", [0, 2, 4, 6, 8, 10])
    shutil.copytree(tmp_path / "calm", tmp_path / "dark")
    from pipeline.exposure import apply_gain

    for f in (tmp_path / "dark").glob("*.png"):  # two thirds of a stop darker, in linear light
        cv2.imwrite(str(f), apply_gain(cv2.imread(str(f)), [0.63] * 3))
    calm = m.judge([(tmp_path / "base", tmp_path / "calm")], "exposure")
    assert calm["relative"]["mean"] < -0.1 and calm["relative"]["mean_farneback"] < -0.1
    assert calm["checks"]["a"] and calm["checks"]["b"] and calm["passes"]
    dark = m.judge([(tmp_path / "base", tmp_path / "dark")], "exposure")
    assert dark["relative"]["brightness"] < -0.15 and not dark["checks"]["c"]
    assert dark["checks"]["a"] and not dark["passes"]
    assert dark["relative"]["sharpness"] < -0.1  # plain sharpness falls with the exposure
    assert abs(dark["relative"]["matched_sharpness"] - calm["relative"]["matched_sharpness"]) < 0.01


def test_video_flicker_bad_input_is_one_line(tmp_path, capsys):
    """benchmarks/video_flicker.py on a missing folder or one with a single frame: one line,
    exit 2."""
    from tests.conftest import load_benchmark

    m = load_benchmark("video_flicker")
    _moving_frames(tmp_path / "one", [0])
    for folder in (tmp_path / "nothing", tmp_path / "one"):
        assert m.main([str(folder)]) == 2
        err = capsys.readouterr().err.strip()
        assert err.startswith("error:") and "\n" not in err and folder.name in err


def test_video_flicker_judges_a_fade_against_its_baseline(tmp_path, capsys):
    """``--judge BASELINE CANDIDATE``: a baseline that pops (one frame 30 % brighter) against
    a candidate with the pop spread over three frames: its largest step falls, its renders
    per frame come from the fades in cameras.json (here too many: it fails), and the frames
    it renders without a fade are checked to the bit against the baseline's."""
    import json
    import shutil

    from tests.conftest import load_benchmark

    m = load_benchmark("video_flicker")
    _moving_frames(tmp_path / "base", [0, 2, 4, 6, 8, 10], gain_at=3, gain=1.3)
    cand = tmp_path / "cand"
    shutil.copytree(tmp_path / "base", cand)
    import cv2
    import numpy as np

    for i in (2, 3, 4):  # the same frames faded: a third of the brightening each
        f = cv2.imread(str(cand / f"{i:05d}.png")).astype(np.float32)
        f = f / 1.3 * 1.1 if i == 3 else f * 1.1
        cv2.imwrite(str(cand / f"{i:05d}.png"), np.clip(f, 0, 255).astype(np.uint8))
    names = [f"{i:05d}" for i in range(6)]
    fades = {"00002": 1, "00003": 2, "00004": 1}
    cams = {"frames": [{"name": n, "sources": ["a"], **({"fades": [{"sources": ["b"],
            "weight": 0.3}] * fades[n]} if n in fades else {})} for n in names]}
    (cand / "cameras.json").write_text(json.dumps(cams))
    res = m.judge([(tmp_path / "base", cand)])
    row = res["builds"][str(cand)]
    assert row["largest"][1] < row["largest"][0] and res["largest_down_on"] == 1
    assert row["renders_per_frame"] == [1.0, (6 + 4) / 6]
    assert row["unfaded_frames"] == 3 and row["unfaded_identical"] == 3 and res["identical"]
    assert res["relative"]["largest"] <= m.RULE["largest"]  # but on one build, not four:
    assert not res["checks"]["a"]  # and 10 images for 6 frames, more than 1.5 a frame:
    assert not res["checks"]["d"] and not res["passes"]
    assert m.main(["--judge", str(tmp_path / "base")]) == 2
    assert "pairs" in capsys.readouterr().err
    # the cut rule (fade_cut) weighs images against the baseline's own: with 1.67 a frame
    # against 1.0 it passes (d), its mean error fell on one path of the three asked
    cut = m.judge([(tmp_path / "base", cand)], "cut")
    assert m.CUT_RULE["renders_ratio"] == 1.7 and cut["checks"]["d"]
    fell = row["mean"][1] < row["mean"][0]
    assert not cut["checks"]["a"] and fell == (cut["relative"]["mean"] < 0)


def test_loo_pairs_tabulates_differences_and_refuses_other_views(tmp_path, capsys):
    """benchmarks/loo_pairs.py: each pair's PSNR / SSIM differences and their mean, each
    pair weighing the same; a pair over other views, or an odd number of files, is one line,
    exit 2."""
    import json

    from tests.conftest import load_benchmark

    m = load_benchmark("loo_pairs")

    def rec(name, psnr, ssim, views=("a", "b")):
        (tmp_path / name).write_text(json.dumps({"psnr": psnr, "ssim": ssim,
                                                 "views": list(views)}))
        return tmp_path / name

    pairs = [(rec("b1", 20.0, 0.60), rec("c1", 20.5, 0.61)),
             (rec("b2", 16.0, 0.40, ("x",)), rec("c2", 15.9, 0.43, ("x",)))]
    res = m.pairs_table(pairs)
    assert res["pairs"][str(tmp_path / "c1")]["d_psnr"] == 0.5
    assert res["mean"]["psnr"] == 0.2 and res["mean"]["ssim"] == 0.02
    assert m.main([str(tmp_path / "b1"), str(rec("c3", 20.0, 0.6, ("z",)))]) == 2
    assert "not the views" in capsys.readouterr().err
    assert m.main([str(tmp_path / "b1")]) == 2


def test_key_share_path_measures_the_lean_as_rendered_and_past_a_twin():
    """benchmarks/key_share_path.py: the share as rendered is ``key_share``'s, to the nearest
    other source (a twin 0.017 away takes it to none at 0.008 from the camera, reach 0.5);
    measured past the twin, the spacing is the next spot's (0.12) and the frame leans."""
    from types import SimpleNamespace

    import numpy as np

    from pipeline.render.fill import key_share
    from tests.conftest import load_benchmark

    m = load_benchmark("key_share_path")
    centres = [np.zeros(3), np.array([0.017, 0, 0]), np.array([0.12, 0, 0])]
    at = np.array([0.008, 0, 0])
    views = [SimpleNamespace(c2w=np.c_[np.eye(3), c]) for c in centres]
    r = m.frame_share(at, centres, 0.5, same_spot=0.03)
    assert r["share"] == pytest.approx(key_share(at, views, 0.5)) == pytest.approx(0.0588, 1e-3)
    assert r["spacing"] == pytest.approx(0.017) and r["spacing_past_twins"] == pytest.approx(0.12)
    assert r["share_past_twins"] == pytest.approx(1 - 0.008 / 0.06)
    # no photo within the spot: the two are the same
    r = m.frame_share(at, centres, 0.5, same_spot=0.01)
    assert r["share"] == r["share_past_twins"]


def test_key_share_path_without_a_workspace_is_one_line(tmp_path, capsys):
    """benchmarks/key_share_path.py on a folder that is no workspace: one line, exit 2."""
    from tests.conftest import load_benchmark

    m = load_benchmark("key_share_path")
    assert m.main([str(tmp_path / "nothing.ws")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error:") and "\n" not in err and "nothing.ws" in err
