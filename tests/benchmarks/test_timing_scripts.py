"""The timing and pose benchmarks (pose_passes, stereo_time, render_speed, finetune_time_ab,
step_parts): what each measures and the one-line errors.

Moved from tests/workflows/test_eval.py, which keeps the tests on its eval scene."""

from __future__ import annotations

import json
import sys

import cv2
import numpy as np
import pytest

from tests.conftest import load_benchmark

pytestmark = pytest.mark.usefixtures("one_torch_thread")


def test_pose_passes_errors_and_kept_pass():
    """benchmarks/pose_passes.py: a model that is the reference under a similarity (rotation,
    scale, shift) scores zero error, one view turned by 2 degrees scores 2 degrees there,
    and the kept pass follows the stage's order and tie rule."""
    from scipy.spatial.transform import Rotation

    pp = load_benchmark("pose_passes")
    rng = np.random.default_rng(0)
    ref = {}
    for i in range(6):
        c2w = np.eye(4)
        c2w[:3, :3] = Rotation.from_rotvec(rng.normal(0, 0.3, 3)).as_matrix()
        c2w[:3, 3] = rng.normal(0, 1, 3)
        ref[f"v{i}"] = c2w
    W = Rotation.from_rotvec([0.3, -0.2, 0.5]).as_matrix()  # model frame = W^T (ref / 2.5 - t)
    est = {}
    for k, c in ref.items():
        e = np.eye(4)
        e[:3, :3] = W.T @ c[:3, :3]
        e[:3, 3] = W.T @ (c[:3, 3] / 2.5 - np.array([1.0, 2.0, 3.0]))
        est[k] = e
    same = pp.pose_errors(est, ref)
    assert same["views"] == 6 and same["rotation_deg_max"] < 1e-6 and same["centre_max"] < 1e-9
    est["v0"] = est["v0"].copy()
    est["v0"][:3, :3] = est["v0"][:3, :3] @ Rotation.from_rotvec([0, 0, np.radians(2)]).as_matrix()
    turned = pp.pose_errors(est, ref)
    assert 1.5 < turned["rotation_deg_max"] < 2.1 and turned["rotation_deg_median"] < 0.5
    assert pp.pose_errors({k: est[k] for k in ("v0", "v1")}, ref) is None  # too few in common
    rows = {"default": {"registered": 3}, "relaxed": {"registered": 3},
            "loose": {"registered": 11}}
    assert pp.chosen_pass(rows, 13, loose=False) == "default"  # a tie keeps the earlier
    assert pp.chosen_pass(rows, 13, loose=True) == "loose"
    rows = {"default": {"registered": 13}, "relaxed": {"registered": 0}, "loose": {"registered": 0}}
    assert pp.chosen_pass(rows, 13, loose=True) == "default"  # nothing left out: no more passes


def test_stereo_time_digest_tells_arrays_apart_by_value_shape_and_type():
    """benchmarks/stereo_time.py's digest: the same arrays give the same digest; one changed
    value, a reshape or another dtype of the same bytes give another."""
    st = load_benchmark("stereo_time")
    a = np.arange(12, dtype=np.float32).reshape(3, 4)
    b = np.ones((2, 2), np.float16)
    ref = st.digest([a, b])
    assert st.digest([a.copy(), b.copy()]) == ref
    c = a.copy()
    c[1, 2] += 1e-6
    assert st.digest([c, b]) != ref
    assert st.digest([a.reshape(4, 3), b]) != ref
    assert st.digest([a.view(np.int32), b]) != ref
    assert st.digest([b, a]) != ref


def test_stereo_time_refuses_a_workspace_without_depth_in_one_line(tmp_path, capsys):
    st = load_benchmark("stereo_time")
    (tmp_path / "ws").mkdir()
    (tmp_path / "ws" / "cameras.json").write_text("{}")
    assert st.main([str(tmp_path / "ws"), "--work", str(tmp_path / "w")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "depth" in err and str(tmp_path / "ws") in err


def test_stereo_time_times_the_depth_stage_with_an_option_and_leaves_the_workspace(tmp_path):
    """``--depth-only --set depth.sgm=...``: the depth stage alone, on a copy, with the
    option; the known share is the copy's depth maps'; the workspace gains no depth maps."""
    import json

    from tests.fixtures import make_plane_workspace

    st = load_benchmark("stereo_time")
    ws = make_plane_workspace(tmp_path / "ws", n_views=4)
    out = tmp_path / "t.json"
    assert st.main([str(ws.root), "--work", str(tmp_path / "w"), "--depth-only",
                    "--set", "depth.sgm=0.1,1", "--out", str(out)]) == 0
    rec = json.loads(out.read_text())
    d = rec["depth_stage"]
    assert d["settings"] == ["depth.sgm=0.1,1"] and d["views"] == 4 and rec["fill"] == []
    assert 0.3 < d["known"] <= 1.0  # a textured plane: most pixels have a depth
    assert not (ws.root / "depth").exists()
    manifest = json.loads((tmp_path / "w" / "ws.depth" / "manifest.json").read_text())
    assert manifest["stages"]["depth"]["params"]["sgm"] == [0.1, 1.0]


def test_render_speed_compares_frames_and_names_bad_settings(tmp_path):
    """render_speed.py: two renders' frames compared value by value (how far, how many), a
    different set of frames named as such; a bad list of settings is a one-line error."""
    rs = load_benchmark("render_speed")
    assert rs.parse_counts("256, 128", "--chunks") == [256, 128]
    for bad in ("", "0,1", "1,1", "a"):
        with pytest.raises(SystemExit, match="--workers"):
            rs.parse_counts(bad, "--workers")
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir(), b.mkdir()
    img = np.zeros((4, 5, 3), np.uint8)
    for folder, value in ((a, 10), (b, 12)):
        cv2.imwrite(str(folder / "00000.png"), img)
        moved = img.copy()
        moved[1, 2, 0] = value
        cv2.imwrite(str(folder / "00001.png"), moved)
    assert rs.frame_diff(rs.frame_pixels(a), rs.frame_pixels(a)) == (0, 0)
    assert rs.frame_diff(rs.frame_pixels(a), rs.frame_pixels(b)) == (2, 1)
    (b / "00002.png").write_bytes((b / "00001.png").read_bytes())
    assert rs.frame_diff(rs.frame_pixels(a), rs.frame_pixels(b)) == (-1, -1)


def test_finetune_time_ab_alternates_arms_on_copies(tmp_path):
    """benchmarks/finetune_time_ab.py: the arms take turns round after round, each on its
    own copy of the workspace (left as it was), with its own arguments and executable; each
    arm's means and ratios to the first come from the stage records; a failing run stops it
    naming its log."""
    bench = load_benchmark("finetune_time_ab")
    ws = tmp_path / "ws"
    ws.mkdir()
    manifest = {"stages": {"finetune": {"seconds": 1.0, "train_seconds": 1.0}}}
    (ws / "manifest.json").write_text(json.dumps(manifest))
    calls = tmp_path / "calls.txt"
    fake = tmp_path / "fake-deflare-scene"  # writes train_seconds = 10 per extra argument + 10
    fake.write_text(f"""#!{sys.executable}
import json, sys
from pathlib import Path
ws, extra = Path(sys.argv[2]), sys.argv[6:]
open({str(calls)!r}, "a").write(ws.name + " " + " ".join(sys.argv[3:]) + "\\n")
if "--fail" in extra:
    sys.exit(3)
m = json.loads((ws / "manifest.json").read_text())
m["stages"]["finetune"] = {{"seconds": 5.0, "train_seconds": 10.0 * (1 + len(extra)),
                            "it_per_s": 2.0, "steps": int(sys.argv[4])}}
(ws / "manifest.json").write_text(json.dumps(m))
""")
    fake.chmod(0o755)
    out = tmp_path / "ab.json"
    assert bench.main([str(ws), "--work", str(tmp_path / "w"), "--arm", "a=", "--arm",
                       "b=--no-pad-views", "--exe", f"a={fake}", "--exe", f"b={fake}",
                       "--iters", "7", "--rounds", "2", "--out", str(out)]) == 0
    assert calls.read_text().split("\n")[:4] == [
        "a --iters 7 --force", "b --iters 7 --force --no-pad-views",
        "a --iters 7 --force", "b --iters 7 --force --no-pad-views"]
    res = json.loads(out.read_text())
    assert [r["arm"] for r in res["runs"]] == ["a", "b", "a", "b"]
    assert res["summary"]["b"]["train_ratio"] == pytest.approx(2.0)
    assert res["summary"]["a"]["train_s"] == pytest.approx(10.0)
    assert json.loads((ws / "manifest.json").read_text()) == manifest
    with pytest.raises(SystemExit, match="b_0.log"):
        bench.main([str(ws), "--work", str(tmp_path / "w2"), "--arm", "a=", "--arm",
                    "b=--fail", "--exe", f"a={fake}", "--exe", f"b={fake}", "--rounds", "1"])
    with pytest.raises(SystemExit, match="--exe c"):
        bench.main([str(ws), "--work", str(tmp_path / "w3"), "--arm", "a=", "--exe",
                    f"c={fake}"])
    with pytest.raises(SystemExit, match="not a workspace"):
        bench.main([str(tmp_path / "w"), "--work", str(tmp_path / "w4"), "--arm", "a="])


def test_step_parts_times_each_part_of_padded_and_stretched_steps(tmp_path, monkeypatch):
    """benchmarks/step_parts.py: every setting (padded or stretched, fp32 or bf16 encoder)
    is timed in each round, each part a positive time that the total sums, on the workspace's
    views as the fine-tune loads them. No warm-up steps here: on a CPU without native bf16
    each emulated step takes seconds, and the warm-up changes only the timings."""
    from tests.pipeline.test_finetune import masked_workspace

    bench = load_benchmark("step_parts")
    monkeypatch.setattr(bench, "WARMUP", 0)
    ws = masked_workspace(tmp_path / "ws")
    out = tmp_path / "parts.json"
    assert bench.main([str(ws.root), "--steps", "1", "--rounds", "1", "--out", str(out)]) == 0
    res = json.loads(out.read_text())
    assert set(res["mean_ms"]) == {"padded_fp32_encoder", "stretched_fp32_encoder",
                                   "padded_encoder_bf16", "stretched_encoder_bf16"}
    for runs in res["runs"].values():
        (run,) = runs
        assert all(run[p] > 0 for p in bench.PARTS)
        assert run["total"] == pytest.approx(sum(run[p] for p in bench.PARTS))
        assert run["bank"][0] == 5 and run["encoder_input"][1] == 3
    with pytest.raises(SystemExit, match="not a workspace"):
        bench.main([str(tmp_path)])



def test_malloc_ab_summary_takes_each_arms_fastest_and_medians():
    """benchmarks/malloc_ab.py: per arm the fastest pass's wall time and the medians of its
    passes; the ratio is the settings' fastest over the plain arm's."""
    ab = load_benchmark("malloc_ab")
    passes = [{"arm": "off", "wall_s": w, "user_s": 10.0, "kernel_s": k, "minor_faults": f}
              for w, k, f in ((20.0, 3.0, 900), (22.0, 5.0, 1100), (21.0, 4.0, 1000))]
    passes += [{"arm": "on", "wall_s": w, "user_s": 9.0, "kernel_s": 0.5, "minor_faults": 50}
               for w in (16.0, 15.0)]
    s = ab.summary(passes)
    assert s["off"]["fastest_wall_s"] == 20.0 and s["on"]["fastest_wall_s"] == 15.0
    assert s["off"]["median_kernel_s"] == 4.0 and s["off"]["median_minor_faults"] == 1000
    assert s["on"]["median_wall_s"] == 15.5
    assert s["fastest_wall_ratio_on_off"] == 0.75
