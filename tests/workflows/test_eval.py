"""`deflare-scene eval` end to end on a tiny synthetic-flare temple scene, and the benchmark
scripts that score its workspaces. The other benchmark scripts' tests are in tests/benchmarks/
(mask scripts, A/B judges, timing)."""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest
import torch

from pipeline import flare as F
from pipeline.synth import SynthConfig
from pipeline.synth import run as synth_run
from tests.conftest import load_benchmark
from tests.fixtures import make_temple_workspace
from workflows.cli import main
from workflows.research.eval.workspaces import link_file, sync_tree

SMALL = F.FlareConfig(psf_size=128, n_psfs=2, n_wavelengths=9, dust_count=(5, 20))


pytestmark = pytest.mark.usefixtures("one_torch_thread")


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    """6 temple views at 1/4 size; seed 0 with flare probability 0.5 leaves 3 clean and 2
    flared training views (>= 2 targets under 10% flare) and 1 held-out view."""
    root = tmp_path_factory.mktemp("eval")
    mp = pytest.MonkeyPatch()
    mp.setenv("DEFLARE_CACHE", str(root / "psf_cache"))
    ws = make_temple_workspace(root / "ws", n_views=6, scale=0.25)
    synth_run(SynthConfig(out=root / "synth", heldout=1, seed=0, flare_prob=0.5, flare=SMALL),
              ws)
    mp.undo()
    return root / "synth"


def _eval(scene, out, *extra):
    return main(["eval", str(scene), "--out", str(out), "--variants", "gnfr,gnt,input,inpaint",
                 "--masks", "gt", "--preset", "tiny", "--iters", "5", "--render-scale", "0.5",
                 "--device", "cpu", *extra])


def test_eval_end_to_end(scene, tmp_path):
    out = tmp_path / "ews"
    assert _eval(scene, out) == 0
    res = json.loads((out / "eval" / "results.json").read_text())
    split = json.loads((scene / "split.json").read_text())
    assert res["heldout_views"] == split["heldout"] and res["masks"] == "gt"
    assert res["budget"]["iters"] == 5 and res["budget"]["preset"] == "tiny"
    assert list(res["methods"]) == ["gnfr", "gnt", "input", "inpaint"]
    # ground-truth masks score perfectly against themselves
    assert res["mask_scores"]["miou"] == pytest.approx(1.0)
    flared = res["scored_input_views"]
    assert flared and set(flared) <= set(split["train"])
    for name, r in res["methods"].items():
        for key in ("psnr", "ssim", "psnr_flare"):
            v = r["inputs"][key]
            assert math.isfinite(v), (name, key, v)
        assert -1 <= r["inputs"]["ssim"] <= 1
        if name in ("gnfr", "gnt"):
            assert set(r["heldout"]["views"]) == set(split["heldout"])
            assert math.isfinite(r["heldout"]["psnr"]) and r["train"]["steps"] == 5
        else:
            assert "heldout" not in r
    # the flared input differs from the ground truth exactly where the flare is
    inp = res["methods"]["input"]["inputs"]
    assert inp["psnr_flare"] < inp["psnr"]
    # the variants really differ in their GN-FR parts (written into their checkpoints)
    from gnfr.checkpoint import read_metadata
    metas = {v: read_metadata(out / "variants" / v / "model" / "gnfr.safetensors")[1]
             for v in ("gnfr", "gnt")}
    flat = {v: json.dumps(m) for v, m in metas.items()}
    assert '"point_sampler": true' in flat["gnfr"] and '"point_sampler": false' in flat["gnt"]
    # held-out renders are at the render scale
    clean = cv2.imread(str(scene / "clean" / f"{split['heldout'][0]}.png"))
    render = cv2.imread(str(out / "variants" / "gnfr" / "renders" / "heldout_cameras" /
                            f"{split['heldout'][0]}.png"))
    assert render.shape[:2] == (round(clean.shape[0] * 0.5), round(clean.shape[1] * 0.5))
    table = (out / "eval" / "table.md").read_text()
    assert "| GN-FR |" in table and "ground truth" in table and "tiny" in table
    # how many views each fine-tune trained on: views.json's targets, all of them for GNT
    views = json.loads((out / "views.json").read_text())["views"]
    flagged = sum(v["target"] for v in views.values())
    assert 2 <= flagged < len(views) == len(split["train"])  # some views over the rule
    assert (res["methods"]["gnfr"]["train"]["targets"], res["methods"]["gnt"]["train"]["targets"],
            res["methods"]["gnt"]["train"]["views"]) == (flagged, len(views), len(views))
    # ... as each variant's fine-tune recorded them (the count is read from the record)
    from pipeline.workspace import Workspace
    gnfr_record = Workspace(out / "variants" / "gnfr").stage_record("finetune")
    assert sorted(gnfr_record["targets"]) == sorted(s for s, v in views.items() if v["target"])
    cells = {ln.split(" | ")[0][2:]: ln.split(" | ") for ln in table.splitlines()
             if ln.startswith("| ") and "---" not in ln}
    assert cells["method"][6] == "targets"
    assert cells["GN-FR"][6] == f"{flagged}/{len(views)}"
    assert cells["GNT (all GN-FR parts off)"][6] == f"{len(views)}/{len(views)}"
    assert cells["flared input (no removal)"][6] == "—"
    # what init resolved to and the colour match are recorded; the summary script reads them
    assert res["budget"]["init_weights"] == "scratch" and res["budget"]["color_match"] is True
    summary = load_benchmark("eval_summary")
    gap = (res["methods"]["gnfr"]["inputs"]["psnr_flare"]
           - res["methods"]["gnt"]["inputs"]["psnr_flare"])
    assert f"| {gap:+.2f} dB |" in summary.summarise([out / "eval" / "results.json"])
    grid = cv2.imread(str(out / "eval" / "grid.jpg"))
    tile_w = round(180 * clean.shape[1] / clean.shape[0])
    rows = len(split["heldout"]) + len(flared)         # 1 held-out + the 2 flared inputs
    cols = 1 + 3 + 1                                   # input, gnfr/gnt/inpaint, truth
    assert grid.shape[:2] == (rows * 180, cols * tile_w)
    # a second run resumes: every stage is skipped, scores are identical
    before = {v: (out / "variants" / v / "model" / "gnfr.safetensors").stat().st_mtime_ns
              for v in ("gnfr", "gnt")}
    assert _eval(scene, out) == 0
    again = json.loads((out / "eval" / "results.json").read_text())
    assert again["methods"] == res["methods"]
    for v, t in before.items():
        assert (out / "variants" / v / "model" / "gnfr.safetensors").stat().st_mtime_ns == t


def test_eval_fmg_masks_scored_against_truth(scene, tmp_path, capsys):
    """With FMG masks (here an untrained tiny FMG) the table reports their mIoU; the
    baselines alone need no training."""
    from gnfr.fmg import build_fmg, save_fmg, tiny_config

    torch.manual_seed(0)
    weights = save_fmg(tmp_path / "fmg.safetensors", build_fmg(tiny_config()))
    out = tmp_path / "ews"
    assert main(["eval", str(scene), "--out", str(out), "--variants", "input,inpaint",
                 "--fmg-weights", str(weights), "--device", "cpu"]) == 0
    res = json.loads((out / "eval" / "results.json").read_text())
    ms = res["mask_scores"]
    assert res["masks"] == "fmg" and 0 <= ms["miou"] < 1 and 0 <= ms["accuracy"] <= 1
    assert f"mIoU {ms['miou']:.3f}" in (out / "eval" / "table.md").read_text()
    assert list(res["methods"]) == ["input", "inpaint"]
    # missing FMG weights: one clear error that also names --masks gt
    assert main(["eval", str(scene), "--out", str(tmp_path / "e2"), "--variants", "input",
                 "--fmg-weights", str(tmp_path / "none.safetensors")]) == 2
    assert "--masks gt" in capsys.readouterr().err


def test_eval_rejects_bad_input(tmp_path, scene, capsys):
    assert main(["eval", str(tmp_path), "--masks", "gt"]) == 2          # not a synth folder
    assert main(["eval", str(scene), "--variants", "gnfr,nerf"]) == 2   # unknown variant
    assert "error: --variants gnfr,nerf: must be one or more of gnfr, gnt" in \
        capsys.readouterr().err
    assert not (scene / "eval.ws").exists()


def test_fit_targets_reads_the_record_and_an_older_record_as_its_code_chose():
    from pipeline.ws_files import make_views
    from workflows.research.eval.methods import fit_targets

    stems = ["a", "b", "c"]
    views = make_views(stems, np.eye(3), {"a": 0.0, "b": 0.5, "c": 0.02}, 0.1)
    assert views.targets() == ["a", "c"]
    assert fit_targets({"targets": ["c"]}, views, True) == ["c"]      # the record wins
    assert fit_targets({"targets": ["c"]}, views, False) == ["c"]
    assert fit_targets({}, views, True) == ["a", "c"]                 # older: views.json
    assert fit_targets({}, views, False) == stems                     # older ablation: all


def test_variant_choices_are_the_variants():
    """The option's choices and default (literals, read by the CLI without importing) are the
    methods eval knows."""
    import dataclasses

    from workflows.research.eval import ALL_VARIANTS, EvalConfig
    from workflows.research.eval.config import LABELS
    from workflows.research.eval_llff import LlffEvalConfig

    fields = {f.name: f for f in dataclasses.fields(EvalConfig)}
    assert fields["variants"].metadata["choices"] == ALL_VARIANTS == tuple(LABELS)
    assert fields["variants"].default == ALL_VARIANTS
    llff = {f.name: f for f in dataclasses.fields(LlffEvalConfig)}
    assert llff["variants"].metadata["choices"] == ALL_VARIANTS


def test_sync_tree_links_and_prunes(tmp_path):
    src, dst = tmp_path / "a", tmp_path / "b"
    src.mkdir()
    (src / "x.png").write_bytes(b"1")
    (src / "y.png").write_bytes(b"2")
    sync_tree(src, dst)
    assert (dst / "x.png").samefile(src / "x.png")
    (src / "y.png").unlink()
    (src / "x.png").unlink()
    (src / "x.png").write_bytes(b"3")   # replaced (a new inode, as atomic writes do)
    sync_tree(src, dst)
    assert sorted(p.name for p in dst.iterdir()) == ["x.png"]
    assert (dst / "x.png").read_bytes() == b"3"
    link_file(src / "x.png", dst / "x.png")   # already linked: a no-op
    assert (dst / "x.png").samefile(src / "x.png")
    # sub-folders (WS/depth/frames) are mirrored and pruned alike; hidden ones left alone
    (src / "frames").mkdir()
    (src / "frames" / "z.npz").write_bytes(b"4")
    (src / ".raw").mkdir()
    (src / ".raw" / "r.npz").write_bytes(b"5")
    sync_tree(src, dst)
    assert (dst / "frames" / "z.npz").samefile(src / "frames" / "z.npz")
    assert not (dst / ".raw").exists()
    shutil.rmtree(src / "frames")
    sync_tree(src, dst)
    assert sorted(p.name for p in dst.iterdir()) == ["x.png"]


def test_shipped_sample_reads_as_a_synth_scene_with_jpeg_photos():
    from workflows.research.eval.scene import load_synth, photo_path

    root = Path(__file__).resolve().parents[2] / "samples" / "cyprus_truth"
    scene = load_synth(root)
    assert len(scene.train) == 8 and len(scene.heldout) == 2 and scene.origin == "cyprus"
    assert all(photo_path(root, s).suffix == ".jpg" for s in scene.train)
    assert photo_path(root, scene.heldout[0]) is None  # held-out views are not photos


def test_mask_downstream_scores_masks_on_copies(scene, tmp_path):
    """benchmarks/mask_downstream.py reruns the mask stage with each weight file on a copy
    of the evaluated variant and scores the re-rendered de-flared inputs; the evaluated
    workspace (true masks) is left as it was."""
    out = tmp_path / "ews"
    assert main(["eval", str(scene), "--out", str(out), "--variants", "gnfr", "--masks", "gt",
                 "--preset", "tiny", "--iters", "3", "--render-scale", "0.5",
                 "--device", "cpu"]) == 0
    src_masks = out / "variants" / "gnfr" / "masks"
    before = {p.name: p.read_bytes() for p in src_masks.iterdir()}
    bench = load_benchmark("mask_downstream")
    shipped = Path(__file__).parents[2] / "gnfr" / "weights" / "fmg.safetensors"
    res = tmp_path / "down.json"
    assert bench.main([str(scene), "--eval-ws", str(out), "--weights", str(shipped),
                       "--truth", "1", "--truth", "3", "--combine", "and,or",
                       "--work", str(tmp_path / "work"), "--out", str(res)]) == 0
    rows = json.loads(res.read_text())["rows"]
    assert len(rows) == 5 and rows[0]["weights"] == str(shipped)
    assert [r.get("truth_scale") for r in rows] == [None, None, None, 1, 3]
    assert [r.get("combine") for r in rows[:3]] == [None, "and true flare 1x", "or true flare 1x"]
    # the masks' match with masks_gt: AND has no false marks, OR no misses, so both match it
    # at least as well as the network's own; the truth at 1x nearly exactly
    iou = [r["flare_iou"] for r in rows]
    assert min(iou[1], iou[2]) >= iou[0] and iou[3] > 0.9
    assert rows[1]["marked"] <= rows[0]["marked"] <= rows[2]["marked"]
    assert all(math.isfinite(r[k]) and r[k] > 0
               for r in rows for k in ("psnr", "psnr_flare", "ssim"))
    assert {p.name: p.read_bytes() for p in src_masks.iterdir()} == before
    copy = tmp_path / "work" / f"{scene.name}_0_weights" / "gnfr"
    rec = json.loads((copy / "manifest.json").read_text())["stages"]["mask"]["params"]
    # the copy's masks are the FMG's, not the truth
    assert rec["weights"].startswith("fmg.safetensors@sha256:") and rec["masks_dir"] is None
    # the truth arms: at 1x the masks are masks_gt (up to the 8-bit photos), at 3x a part
    from pipeline.ws_files import read_mask_file

    def ws_masks(arm):
        d = tmp_path / "work" / f"{scene.name}_{arm}" / "gnfr" / "masks"
        return {p.stem: read_mask_file(p, "") for p in sorted(d.glob("*.png"))}
    one, three = ws_masks("truth1"), ws_masks("truth3")
    gt = {s: read_mask_file(scene / "masks_gt" / f"{s}.png", "") for s in one}
    inter = sum(int((one[s] & gt[s]).sum()) for s in one)
    union = sum(int((one[s] | gt[s]).sum()) for s in one)
    assert union > 0 and inter / union > 0.9
    marked = [sum(int(m.sum()) for m in arm.values()) for arm in (three, one)]
    assert 0 < marked[0] < 0.8 * marked[1]
    assert all(not (three[s] & ~one[s]).any() for s in one)


def test_novel_loo_heldout_and_leave_one_out(scene, tmp_path):
    """benchmarks/novel_loo.py scores the eval's held-out cameras with --heldout and every
    training camera otherwise, and leaves the evaluated variant's views.json as it was."""
    out = tmp_path / "ews"
    assert main(["eval", str(scene), "--out", str(out), "--variants", "gnfr", "--masks", "gt",
                 "--preset", "tiny", "--iters", "3", "--render-scale", "0.5",
                 "--device", "cpu"]) == 0
    views_json = out / "variants" / "gnfr" / "views.json"
    before = views_json.read_bytes()
    bench = load_benchmark("novel_loo")
    split = json.loads((scene / "split.json").read_text())
    for flag, stems in (([], split["train"]), (["--heldout"], split["heldout"])):
        res = tmp_path / f"loo{len(flag)}.json"
        assert bench.main([str(scene), "--eval-ws", str(out), "--scale", "0.25",
                           "--set", "render.fill=network", *flag, "--out", str(res)]) == 0
        rec = json.loads(res.read_text())
        assert rec["views"] == stems and sorted(rec["per_view"]) == sorted(stems)
        assert rec["heldout"] is bool(flag) and 0 < rec["psnr"] < 60 and 0 < rec["ssim"] <= 1
        if flag:  # --ws: the fine-tuned workspace itself renders the same frames
            res_ws = tmp_path / "loo_ws.json"
            assert bench.main([str(scene), "--ws", str(out / "variants" / "gnfr"), "--scale",
                               "0.25", "--set", "render.fill=network", *flag,
                               "--out", str(res_ws)]) == 0
            assert json.loads(res_ws.read_text())["per_view"] == rec["per_view"]
            with pytest.raises(SystemExit, match="exclude each other"):
                bench.main([str(scene), "--ws", str(out), "--eval-ws", str(out), *flag])
    # --deflared: each scratch workspace renders its de-flared photos without the left-out
    # view, and the variant's cameras.json stays as it was
    cams_json = out / "variants" / "gnfr" / "cameras.json"
    cams_before = cams_json.read_bytes()
    res = tmp_path / "loo_deflared.json"
    assert bench.main([str(scene), "--eval-ws", str(out), "--scale", "0.25", "--deflared",
                       "--set", "render.fill=network", "--set", "render.from_deflared=true",
                       "--out", str(res)]) == 0
    rec = json.loads(res.read_text())
    assert rec["deflared"] is True and rec["views"] == split["train"]
    assert 0 < rec["psnr"] < 60
    assert cams_json.read_bytes() == cams_before
    assert views_json.read_bytes() == before


def test_score_workspace_matches_eval(scene, tmp_path):
    """benchmarks/score_workspace.py scores an evaluated variant's de-flared inputs and
    held-out renders to exactly the numbers eval wrote in results.json."""
    out = tmp_path / "ews"
    assert main(["eval", str(scene), "--out", str(out), "--variants", "gnfr", "--masks", "gt",
                 "--preset", "tiny", "--iters", "3", "--render-scale", "0.5",
                 "--device", "cpu"]) == 0
    bench = load_benchmark("score_workspace")
    var = out / "variants" / "gnfr"
    res = tmp_path / "score.json"
    assert bench.main([str(scene), str(var), "--heldout",
                       str(var / "renders" / "heldout_cameras"), "--out", str(res)]) == 0
    got = json.loads(res.read_text())
    want = json.loads((out / "eval" / "results.json").read_text())["methods"]["gnfr"]
    for part, keys in (("inputs", ("psnr", "psnr_flare", "ssim")), ("heldout", ("psnr", "ssim"))):
        for k in keys:
            assert got[part][k] == pytest.approx(want[part][k], abs=1e-9)
    assert got["stages"]["finetune"]["train"]["iters"] == 3
    views = json.loads((var / "views.json").read_text())["views"]
    assert got["targets"] == {"targets": sum(v["target"] for v in views.values()),
                              "views": len(views)}


def test_truth_mask_at_a_smaller_frame_keeps_pixels_half_covered(scene):
    """The region score of a frame smaller than the photos (the novel frames at the photos'
    cameras): the true mask at the frame's size marks the pixels at least half covered."""
    from workflows.research.eval.scene import load_synth, truth_mask

    synth = load_synth(scene)
    stem = next(s for s in synth.train if truth_mask(synth, s).any())
    full = truth_mask(synth, stem)
    assert (truth_mask(synth, stem, full.shape) == full).all()
    assert full.shape[0] % 2 == 0 == full.shape[1] % 2  # a factor of exactly 2 below
    h, w = full.shape[0] // 2, full.shape[1] // 2
    small = truth_mask(synth, stem, (h, w))
    cover = full[:2 * h, :2 * w].reshape(h, 2, w, 2).mean(axis=(1, 3))
    assert small.shape == (h, w) and small.dtype == bool
    assert (small == (cover >= 0.5)).all()


def test_mask_cross_render_swaps_masks_on_copies(scene, tmp_path, capsys):
    """benchmarks/mask_cross_render.py: an arm rendered with its own masks reproduces the
    score eval wrote; with the other arm's masks (here none marked) the renders change; the
    arms' workspaces are left as they were; bad input is one line, exit 2."""
    import shutil

    out = tmp_path / "ews"
    assert main(["eval", str(scene), "--out", str(out), "--variants", "gnfr", "--masks", "gt",
                 "--preset", "tiny", "--iters", "3", "--render-scale", "0.5",
                 "--device", "cpu"]) == 0
    a = out / "variants" / "gnfr"
    b = tmp_path / "b.ws"
    shutil.copytree(a, b, symlinks=True)
    for m in (b / "masks").glob("*.png"):  # arm b: nothing marked
        cv2.imwrite(str(m), np.zeros_like(cv2.imread(str(m), cv2.IMREAD_GRAYSCALE)))
    xr = load_benchmark("mask_cross_render")
    cams = out / "eval" / "heldout_cameras.json"
    before = sorted(p.relative_to(a) for p in a.rglob("*"))
    res = tmp_path / "xr.json"
    assert xr.main([str(scene), "--arm", f"a={a}", "--arm", f"b={b}", "--cameras", str(cams),
                    "--variants", "own,othermasks,nearest", "--out", str(res)]) == 0
    rows = {(r["model"], r["render"]): r["heldout"]["psnr"]
            for r in json.loads(res.read_text())["rows"]}
    want = json.loads((out / "eval" / "results.json").read_text())["methods"]["gnfr"]
    assert rows[("a", "own")] == pytest.approx(want["heldout"]["psnr"], abs=1e-9)
    assert rows[("a", "othermasks")] != rows[("a", "own")]  # the attention masks matter
    assert len(rows) == 6 and not (tmp_path / "xr.work").exists()
    assert sorted(p.relative_to(a) for p in a.rglob("*")) == before
    assert xr.main([str(scene), "--arm", f"a={a}", "--cameras", str(cams),
                    "--out", str(tmp_path / "x.json")]) == 2
    assert xr.main([str(scene), "--arm", f"a={a}", "--arm", f"b={tmp_path}",
                    "--cameras", str(cams), "--out", str(tmp_path / "x.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-2].startswith("error: --arm given 1 times")
    assert "is not a fine-tuned workspace" in err[-1] and not (tmp_path / "x.json").exists()


def test_benchmarks_render_in_a_scratch_copy_and_name_what_a_workspace_lacks(tmp_path):
    """``scratch_workspace`` (the render benchmarks' copy): a workspace without depth maps is
    a one-line error naming the depth stage; with them the benchmark gets the workspace, its
    model and a scratch workspace elsewhere that shares its stages and is gone after, the
    workspace untouched. inputs_sources_time.py names a bad ``--sources``."""
    from tests.pipeline.render_ws import make_render_ws
    from workflows.research.bench import scratch_workspace

    ws = make_render_ws(tmp_path / "ws")
    with pytest.raises(SystemExit, match="^error: .*depth"), scratch_workspace(ws.root, "t-"):
        pass
    ws.depth.mkdir()
    before = sorted(p.relative_to(ws.root) for p in ws.root.rglob("*"))
    with scratch_workspace(ws.root, "t-") as (base, ckpt, scratch):
        assert base.root == ws.root and ckpt == ws.model_file
        assert scratch.root != ws.root and scratch.stage_record("pose")
        assert sorted(p.name for p in scratch.images.iterdir()) == \
            sorted(p.name for p in ws.images.iterdir())
        kept = scratch.root
    assert not kept.exists()
    assert sorted(p.relative_to(ws.root) for p in ws.root.rglob("*")) == before
    bench = load_benchmark("inputs_sources_time")
    with pytest.raises(SystemExit, match="--sources"):
        bench.main(["--workspace", str(ws.root), "--sources", "0,6"])


def test_heldout_swap_reproduces_the_eval_and_swaps_models(scene, tmp_path, capsys):
    """benchmarks/heldout_swap.py: each model with its own variant's sources scores exactly
    what eval wrote for its held-out views; the swapped arms render too; the evaluation
    workspace is not written; a workspace without eval's results is one line, exit 2."""
    out = tmp_path / "ews"
    assert main(["eval", str(scene), "--out", str(out), "--variants", "gnfr,gnt", "--masks",
                 "gt", "--preset", "tiny", "--iters", "3", "--render-scale", "0.5",
                 "--device", "cpu"]) == 0
    before = {p: p.stat().st_mtime_ns for p in out.rglob("*") if p.is_file()}
    bench = load_benchmark("heldout_swap")
    res = tmp_path / "swap.json"
    assert bench.main([str(scene), str(out), "--work", str(tmp_path / "work"),
                       "--out", str(res)]) == 0
    got = json.loads(res.read_text())
    want = json.loads((out / "eval" / "results.json").read_text())["methods"]
    for m in ("gnfr", "gnt"):
        assert got["arms"][f"{m}_model_{m}_sources_hybrid"]["psnr"] == pytest.approx(
            want[m]["heldout"]["psnr"], abs=1e-9)
    crossed = got["arms"]["gnfr_model_gnt_sources_hybrid"]
    assert crossed["model"] == "gnfr" and crossed["sources"] == "gnt"
    assert math.isfinite(crossed["psnr"]) and set(crossed["views"]) == set(got["heldout_views"])
    assert len(got["arms"]) == 4 and set(got["models_sha256"]) == {"gnfr", "gnt"}
    assert {p: p.stat().st_mtime_ns for p in out.rglob("*") if p.is_file()} == before
    capsys.readouterr()
    assert bench.main([str(scene), str(tmp_path / "nothing"), "--work",
                       str(tmp_path / "w2")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "results.json is missing" in err[0]
    assert bench.main([str(scene), str(out), "--work", str(tmp_path / "w3"),
                       "--fills", "blur"]) == 2
    assert "blur is no fill" in capsys.readouterr().err
    # a SYNTH folder other than the one eval ran on (here: one more held-out view) is refused
    # before anything renders
    other = tmp_path / "other_synth"
    shutil.copytree(scene, other)
    split = json.loads((other / "split.json").read_text())
    split["heldout"] = [*split["heldout"], split["train"][0]]
    (other / "split.json").write_text(json.dumps(split))
    assert bench.main([str(other), str(out), "--work", str(tmp_path / "w4")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "was not evaluated on" in err[0] and "held-out views differ" in err[0]
    assert not (tmp_path / "w4").exists() or not any((tmp_path / "w4").iterdir())
