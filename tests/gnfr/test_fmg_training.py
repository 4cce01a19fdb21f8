"""FMG commands: `fmg train` (resume, best validation, workers, bad data), `fmg eval` in every
mode (leave-one-kind-out, negatives, clean photos with pads), overlay labels, checkpoints."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from gnfr.fmg import build_fmg, load_fmg, save_fmg, tiny_config
from tests.conftest import shared


def _tiny_data(tmp_path):
    """A data folder with one photo in each part: training (scenes/et, a background),
    development (the FMG's dev scene) and test (a test scene)."""
    import shutil

    from pipeline.scene_splits import FMG_DEV_SCENES

    kermit = shared("scenes", "kermit")
    data = tmp_path / "data"
    for sub, name in (("scenes/kermit", "kermit000.jpg"), ("scenes/et", "kermit001.jpg"),
                      ("backgrounds/misc", "kermit002.jpg"),
                      (f"scenes/{FMG_DEV_SCENES[0]}", "kermit003.jpg")):
        (data / sub).mkdir(parents=True)
        shutil.copy(kermit / name, data / sub / name)
    return data


def test_fmg_train_cli_resumes_and_evaluates(tmp_path, capsys):
    import json

    from workflows.cli import main

    data = _tiny_data(tmp_path)
    out = tmp_path / "run"
    args = ["fmg", "train", "--out", str(out), "--data", str(data), "--batch", "2",
            "--size", "64", "--widths", "8,8,16,16", "--depths", "1,1,1,1", "--head-width",
            "16", "--ckpt-every", "1", "--eval-every", "100", "--val-count", "2"]
    assert main([*args, "--iters", "2"]) == 0
    assert main([*args, "--iters", "3", "--workers", "1"]) == 0  # resumes at step 2
    steps = [json.loads(line)["step"] for line in (out / "log.jsonl").read_text().splitlines()]
    assert steps == [1, 2, 3]
    # a resume under other settings (here a kind left out) is refused, naming the option,
    # before anything is trained or written
    capsys.readouterr()
    assert main([*args, "--iters", "4", "--without", "ghosts"]) == 2
    assert "was started with --without none (now ghosts)" in capsys.readouterr().err
    # --night-glare at 1 is the run as started (the option's value before it existed);
    # another value is another run
    assert main([*args, "--iters", "4", "--night-glare", "0.5"]) == 2
    assert "was started with --night-glare none (now 0.5)" in capsys.readouterr().err
    assert len((out / "log.jsonl").read_text().splitlines()) == 3
    metrics = json.loads((out / "metrics.json").read_text())
    from workflows.research.fmg_eval import evaluate

    # the file holds the final model's scores on the development part (val-count 2, doubled)
    again = evaluate(out / "fmg.safetensors", data, count=4, size=64, split="dev")
    assert metrics["split"] == "dev"
    for row in ("default", "unseen", "night"):
        assert metrics[row]["mIoU"] == pytest.approx(again[row]["mIoU"], abs=1e-9)
        assert metrics[row]["flare_pixels"] == again[row]["flare_pixels"] > 0
    model = load_fmg(out / "fmg.safetensors")
    assert model.cfg.widths == (8, 8, 16, 16)
    assert main(["fmg", "eval", "--weights", str(out / "fmg.safetensors"), "--data", str(data),
                 "--count", "2", "--size", "64", "--out", str(tmp_path / "m.json")]) == 0
    assert json.loads((tmp_path / "m.json").read_text())["count"] == 2
    # calibrate: sweep the cut on development composites and store the chosen one
    from safetensors.torch import load_file

    from gnfr.fmg import read_fmg_metadata

    w = out / "fmg.safetensors"
    before = load_file(str(w))
    assert main(["fmg", "calibrate", "--weights", str(w), "--data", str(data), "--count", "4",
                 "--write", "--out", str(tmp_path / "cal.json")]) == 0
    cal = json.loads((tmp_path / "cal.json").read_text())
    marked = [r["marked_over_true"] for r in cal["rows"]]
    assert all(a >= b for a, b in zip(marked, marked[1:], strict=False))  # higher: no more
    assert cal["best"] in [r["cut"] for r in cal["rows"]]
    assert float(read_fmg_metadata(w)["threshold"]) == cal["best"]
    after = load_file(str(w))
    assert before.keys() == after.keys() and all(torch.equal(before[k], after[k]) for k in before)



def test_leave_one_kind_out_trains_and_scores(tmp_path, monkeypatch):
    """A leave-one-kind-out run at tiny size: trains without a kind (recorded in the
    weights), then `fmg eval --per-kind` scores it on that kind beside another model."""
    import json

    from gnfr.fmg import read_fmg_metadata
    from pipeline import flare as fl
    from workflows.cli import main

    data = _tiny_data(tmp_path)
    tiny = ["--data", str(data), "--iters", "2", "--batch", "2", "--size", "64", "--widths",
            "8,8,16,16", "--depths", "1,1,1,1", "--head-width", "16", "--eval-every", "100",
            "--val-count", "2"]
    assert main(["fmg", "train", "--out", str(tmp_path / "loo"), "--without", "streaks",
                 *tiny]) == 0
    loo = tmp_path / "loo" / "fmg.safetensors"
    meta = read_fmg_metadata(loo)
    assert meta["without"] == "streaks" and "streaks" not in meta["kinds"].split(",")
    # --init starts a run from other weights of the same shape
    assert main(["fmg", "train", "--out", str(tmp_path / "all"), "--init", str(loo),
                 *tiny]) == 0
    allw = tmp_path / "all" / "fmg.safetensors"
    assert read_fmg_metadata(allw)["without"] == ""
    assert read_fmg_metadata(allw)["total_iters"] == "4"
    assert main(["fmg", "eval", "--per-kind", "--weights", str(allw), "--loo", str(loo),
                 "--data", str(data), "--count", "2", "--size", "64",
                 "--out", str(tmp_path / "k.json")]) == 0
    res = json.loads((tmp_path / "k.json").read_text())
    assert list(res["kinds"]) == list(fl.KINDS)
    for kind, row in res["kinds"].items():
        assert row["flare_pixels"] > 0
        assert ("without" in row) == (kind == "streaks")
    assert res["kinds"]["streaks"]["without"]["steps"] == 2
    # --ray-min / --ray-opposite reach the ray rule the scores use, and are recorded
    import pipeline.flare_rays as fr

    seen, real = [], fr.ray_mask
    monkeypatch.setattr(fr, "ray_mask", lambda img, cfg=None: seen.append(cfg) or real(img, cfg))
    assert main(["fmg", "eval", "--per-kind", "--weights", str(allw), "--data", str(data),
                 "--count", "2", "--size", "64", "--rays", "--ray-min", "1",
                 "--ray-opposite", "8", "--out", str(tmp_path / "r.json")]) == 0
    assert seen and all((c.min_rays, c.opposite) == (1, 8.0) for c in seen)
    rule = json.loads((tmp_path / "r.json").read_text())["ray_rule"]
    assert (rule["min_rays"], rule["opposite"]) == (1, 8.0)
    # --ghost-lines: every composite's mask goes through the ghost-line rule, recorded
    import pipeline.flare_ghosts as fg

    ghosts_seen, real_g = [], fg.ghost_line_mask
    monkeypatch.setattr(fg, "ghost_line_mask", lambda p, lights, centre=None, cfg=None:
                        ghosts_seen.append(cfg) or real_g(p, lights, centre, cfg))
    assert main(["fmg", "eval", "--per-kind", "--weights", str(allw), "--data", str(data),
                 "--count", "2", "--size", "64", "--ghost-lines",
                 "--out", str(tmp_path / "g.json")]) == 0
    assert len(ghosts_seen) == 2 * len(fl.KINDS)  # two composites per kind
    assert json.loads((tmp_path / "g.json").read_text())["ghost_lines"]["min_chain"] == 2
    assert json.loads((tmp_path / "k.json").read_text())["ghost_lines"] is None
    # --negatives: flare-free composites with each named negative, the rays' rule recorded
    assert main(["fmg", "eval", "--negatives", "backlit,lamp", "--weights", str(allw),
                 "--data", str(data), "--count", "2", "--size", "64", "--split", "dev",
                 "--rays", "--out", str(tmp_path / "n.json")]) == 0
    neg = json.loads((tmp_path / "n.json").read_text())
    assert list(neg["negatives"]) == ["backlit", "lamp"] and neg["split"] == "dev"
    assert neg["ray_rule"] is not None and neg["count"] == 2
    assert all(0 <= r["mean"] <= r["max"] <= 1 for r in neg["negatives"].values())
    # the overview image of masks on photos
    jpg = tmp_path / "overlay.jpg"
    photo = data / "scenes/kermit/kermit000.jpg"
    assert main(["fmg", "overlay", str(photo), "--weights", str(allw),
                 "--weights", str(loo), "--out", str(jpg), "--work-size", "64",
                 "--json", str(tmp_path / "o.json")]) == 0
    import cv2

    assert cv2.imread(str(jpg)).shape[1] == 3 * 480
    shares = json.loads((tmp_path / "o.json").read_text())["marked"]
    assert sorted(shares) == sorted(f"{photo.name} {w}" for w in (allw, loo))
    assert all(0 <= v <= 1 for v in shares.values())
    # --fill-holes marks what each mask encloses too: never less, and recorded
    assert main(["fmg", "overlay", str(photo), "--weights", str(allw),
                 "--weights", str(loo), "--out", str(jpg), "--work-size", "64",
                 "--fill-holes", "--json", str(tmp_path / "oh.json")]) == 0
    filled = json.loads((tmp_path / "oh.json").read_text())
    assert filled["fill_holes"] is True
    assert all(filled["marked"][k] >= v for k, v in shares.items())
    ghosts_seen.clear()
    assert main(["fmg", "overlay", str(photo), "--weights", str(allw), "--out", str(jpg),
                 "--work-size", "64", "--ghost-lines"]) == 0
    assert len(ghosts_seen) == 1 and cv2.imread(str(jpg)).shape[1] == 2 * 480
    # --pads: the regions the padded runs agree on, as the mask stage's default keeps them
    from pipeline.images import read_image
    from pipeline.mask import fmg_probs_pair, load_fmg_weights, regions_touching
    from workflows.research.fmg_eval import real_flare_overview, weights_info

    pads = ("reflect", "constant")
    got = {(p, k): real_flare_overview((allw,), (photo,), jpg, 64, pads=p, pads_keep=k)
           for p, k in (((), "pixels"), (pads, "pixels"), (pads, "regions"))}
    model, img = load_fmg_weights(allw), read_image(photo, bgr=True)
    plain, agreed = fmg_probs_pair(model, [img], 64, (1.0,), pads)
    cut = weights_info(allw)["cut"]
    key = f"{photo.name} {allw}"
    assert got[(), "pixels"][key] == pytest.approx((plain[0] > cut).mean())
    assert got[pads, "pixels"][key] == pytest.approx((agreed[0] > cut).mean())
    assert got[pads, "regions"][key] == pytest.approx(
        regions_touching(plain[0] > cut, agreed[0] > cut).mean())
    assert got[pads, "pixels"][key] <= got[pads, "regions"][key] <= got[(), "pixels"][key]
    # every score has its fill ceiling; --fill-holes scores the masks with holes filled
    assert all(r["weights"]["flare_psnr_ceiling"] > 0 for r in res["kinds"].values())
    assert res["fill_holes"] is False
    assert main(["fmg", "eval", "--per-kind", "--weights", str(allw), "--data", str(data),
                 "--count", "2", "--size", "64", "--fill-holes",
                 "--out", str(tmp_path / "h.json")]) == 0
    holes = json.loads((tmp_path / "h.json").read_text())
    assert holes["fill_holes"] is True
    for kind, row in holes["kinds"].items():  # filling only adds marks: the ceiling only rises
        assert (row["weights"]["flare_psnr_ceiling"]
                >= res["kinds"][kind]["weights"]["flare_psnr_ceiling"] - 1e-9)
    assert main(["fmg", "eval", "--fill-holes", "--weights", str(allw), "--data", str(data),
                 "--count", "2", "--size", "64"]) != 0  # --fill-holes needs --per-kind
    # weights trained on every kind cannot stand in for a leave-one-kind-out model
    assert main(["fmg", "eval", "--per-kind", "--loo", str(allw), "--data", str(data),
                 "--count", "2", "--size", "64"]) != 0


def test_fmg_train_flare_prob_sets_the_share_of_clean_composites():
    """`fmg train --flare-prob` reaches the composites: 0 gives only clean training
    composites (empty masks), 1 flare on most (an invisible draw leaves a mask empty)."""
    from pathlib import Path
    from unittest import mock

    import pipeline.fmg_data as fd
    from workflows.research.fmg_train import FMGTrainConfig, _sources

    assert FMGTrainConfig.__dataclass_fields__["flare_prob"].default == 0.8
    bgs = [np.random.default_rng(i).uniform(0.1, 0.6, (96, 128, 3)).astype(np.float32)
           for i in range(3)]
    split = fd.PhotoSplit(train=[Path("a")], dev=[], test=[])
    with mock.patch.object(fd, "split_backgrounds", return_value=split), \
            mock.patch.object(fd, "load_backgrounds", return_value=bgs), \
            mock.patch("workflows.research.fmg_train._part_backgrounds", return_value=[]):
        shares = {}
        for p in (0.0, 1.0):
            src, _, comp, _ = _sources(Path("unused"), 64, flare_prob=p)
            assert comp.flare_prob == p
            rng = np.random.default_rng(0)
            shares[p] = np.mean([src.sample(rng)[1].any() for _ in range(12)])
    assert shares[0.0] == 0.0 and shares[1.0] > 0.5, shares


def test_a_run_from_init_resumed_without_it_still_counts_the_init_steps(tmp_path):
    """Steps are counted from scratch: a run started with --init records the init file's
    steps in its checkpoint, so resuming it without --init still adds them."""
    from gnfr.fmg import read_fmg_metadata
    from workflows.cli import main

    data = _tiny_data(tmp_path)
    args = ["fmg", "train", "--data", str(data), "--batch", "2", "--size", "64", "--widths",
            "8,8,16,16", "--depths", "1,1,1,1", "--head-width", "16", "--ckpt-every", "1",
            "--eval-every", "100", "--val-count", "2"]
    assert main([*args, "--out", str(tmp_path / "a"), "--iters", "2"]) == 0
    init = tmp_path / "a" / "fmg.safetensors"
    assert main([*args, "--out", str(tmp_path / "b"), "--iters", "2", "--init", str(init)]) == 0
    assert read_fmg_metadata(tmp_path / "b" / "checkpoint.safetensors")["init_iters"] == "2"
    assert main([*args, "--out", str(tmp_path / "b"), "--iters", "3"]) == 0  # no --init
    assert read_fmg_metadata(tmp_path / "b" / "checkpoint.safetensors")["init_iters"] == "2"
    assert read_fmg_metadata(tmp_path / "b" / "fmg.safetensors")["total_iters"] == "5"


def test_overlay_columns_are_named_by_the_file_or_its_run():
    from pathlib import Path

    from workflows.research.fmg_eval import weights_label

    assert weights_label(Path("gnfr/weights/fmg_candidate_L.safetensors")) == "fmg_candidate_L"
    assert weights_label(Path("gnfr/weights/fmg.safetensors")) == "weights/fmg"
    assert weights_label(Path("/runs/k2/best.safetensors")) == "k2/best"
    assert weights_label(Path("fmg.safetensors")) == "fmg"


def test_overlay_labels_name_every_option_that_added_marks():
    from pathlib import Path

    from pipeline.flare_rays import RayConfig
    from workflows.research.fmg_eval import overlay_label

    w = Path("gnfr/weights/fmg.safetensors")
    assert overlay_label(w, 0.0541, False, None, False, False) == "weights/fmg: 5.4 %"
    assert (overlay_label(w, 0.07, True, RayConfig(cores=True), True, True)
            == "weights/fmg + rays + light cores + ghost lines + pads: 7.0 %")
    assert (overlay_label(w, 0.07, True, RayConfig(lines=True), False, False)
            == "weights/fmg + rays + streak lines: 7.0 %")
    assert (overlay_label(w, 0.07, False, None, False, True, holes=True)
            == "weights/fmg + pads + holes filled: 7.0 %")
    assert (overlay_label(w, 0.07, True, RayConfig(lines=True, line_scales=(1.0, 0.25)),
                          False, False)
            == "weights/fmg + rays + streak lines at 1,0.25: 7.0 %")
    # cores or lines without rays add nothing, so the label does not claim them
    assert (overlay_label(w, 0.07, False, RayConfig(cores=True), False, False)
            == "weights/fmg: 7.0 %")


def test_export_checkpoint_gives_weights_that_load_and_count_their_steps(tmp_path):
    """A run cut short (a lent GPU given back) leaves fp16 weights from its checkpoint."""
    from workflows.research.fmg_eval import weights_info
    from workflows.research.fmg_train import export_checkpoint, save_checkpoint

    torch.manual_seed(0)
    model = build_fmg(tiny_config())
    opt = torch.optim.AdamW(model.parameters(), lr=1e-3)
    save_checkpoint(tmp_path, model, opt, 7, init_steps=100)
    dest = export_checkpoint(tmp_path, tmp_path / "fmg.safetensors")  # the recorded init
    assert weights_info(dest)["steps"] == 107
    assert weights_info(export_checkpoint(tmp_path, tmp_path / "b.safetensors",
                                          init_steps=5))["steps"] == 12
    back = load_fmg(dest)
    for (k, a), (_, b) in zip(model.state_dict().items(), back.state_dict().items(),
                              strict=True):
        if a.is_floating_point():
            assert torch.allclose(a, b.float(), atol=2e-3, rtol=2e-3), k
    from pipeline.errors import UserError
    with pytest.raises(UserError, match="no checkpoint"):
        export_checkpoint(tmp_path / "empty", tmp_path / "x.safetensors")
    with pytest.raises(UserError, match="no best.safetensors"):
        export_checkpoint(tmp_path, tmp_path / "x.safetensors", best=True)


def test_fmg_train_keeps_the_weights_of_best_validation(tmp_path, monkeypatch):
    """``best.safetensors`` holds the weights of the step whose validation flare IoU was
    highest (the first such step on a tie: only a strictly higher score replaces it), kept
    across a resume, and exports like the checkpoint."""
    from safetensors.torch import load_file

    import workflows.research.fmg_train as ft
    from gnfr.fmg import read_fmg_metadata
    from workflows.cli import main

    scores = iter([0.2, 0.5, 0.3, 0.5, 0.4, 0.6, 0.1])  # best: step 2, then step 6
    states = {}
    real = ft.score

    def fake(model, *val, **kw):
        out = real(model, *val, **kw)
        if kw:  # the end-of-run evaluation, not the training loop's validation
            return out
        states[len(states) + 1] = {k: v.detach().clone() for k, v in model.state_dict().items()}
        return {**out, "IoU_flare": next(scores)}

    monkeypatch.setattr(ft, "score", fake)
    data = _tiny_data(tmp_path)
    out = tmp_path / "run"
    args = ["fmg", "train", "--out", str(out), "--data", str(data), "--batch", "2",
            "--size", "64", "--widths", "8,8,16,16", "--depths", "1,1,1,1", "--head-width",
            "16", "--ckpt-every", "1", "--eval-every", "1", "--val-count", "2"]

    def best():
        meta = read_fmg_metadata(out / "best.safetensors")
        kept = load_file(str(out / "best.safetensors"))
        same = all(torch.equal(kept[k], states[int(meta["step"])][k].cpu()) for k in kept)
        return int(meta["step"]), float(meta["val_IoU_flare"]), same

    assert main([*args, "--iters", "4"]) == 0
    assert best() == (2, 0.5, True)
    assert main([*args, "--iters", "7", "--workers", "1"]) == 0  # resumes at step 4
    assert best() == (6, 0.6, True)
    # the steps' weights differ, so matching step 6's is a real check
    assert any(not torch.equal(states[6][k], states[7][k]) for k in states[6])
    dest = ft.export_checkpoint(out, tmp_path / "best16.safetensors", best=True)
    exported, kept = load_file(str(dest)), load_file(str(out / "best.safetensors"))
    assert exported.keys() == kept.keys()
    assert all(torch.allclose(exported[k].float(), kept[k].float(), atol=2e-3, rtol=2e-3)
               for k in kept if kept[k].is_floating_point())
    assert read_fmg_metadata(dest)["iters"] == "6"


def test_train_batches_from_workers_do_not_depend_on_their_number():
    """`fmg train --workers N`: step s's composites come from a generator seeded by
    (seed, s), so 1 or 2 worker processes give the same batches, a run resumed at step s
    draws what the uninterrupted run drew there, and different steps differ."""
    import pipeline.fmg_data as fd
    from pipeline.flare import FlareConfig
    from workflows.research.fmg_train import TrainBatches

    bgs = [np.random.default_rng(i).uniform(0.1, 0.6, (96, 128, 3)).astype(np.float32)
           for i in range(3)]
    src = fd.CompositeSource(bgs, FlareConfig(), fd.CompositeConfig(size=48))
    runs = {}
    for workers in (1, 2):
        b = TrainBatches(src, 2, seed=3, workers=workers)
        b.begin(5)
        try:
            runs[workers] = [b.next() for _ in range(3)]  # steps 5, 6, 7
        finally:
            b.close()
    resumed = TrainBatches(src, 2, seed=3, workers=1)
    resumed.begin(6)
    try:
        at6 = resumed.next()
    finally:
        resumed.close()
    for (x1, y1), (x2, y2) in zip(runs[1], runs[2], strict=True):
        assert x1.shape == (2, 3, 48, 48) and torch.equal(x1, x2) and torch.equal(y1, y2)
    assert torch.equal(at6[0], runs[1][1][0]) and torch.equal(at6[1], runs[1][1][1])
    assert not torch.equal(runs[1][0][0], runs[1][1][0])
    # in-process drawing (workers 0) is the original single stream
    inproc = TrainBatches(src, 2, seed=3, workers=0)
    inproc.begin(5)
    x0, _ = inproc.next()
    ref, _ = src.batch(2, np.random.default_rng([3, 5]))
    assert torch.equal(x0, ref)


def test_fmg_train_with_bad_data_or_init_stops_with_one_line_and_makes_no_folder(tmp_path,
                                                                                  capsys):
    import cv2

    from workflows.cli import main

    (tmp_path / "data" / "backgrounds").mkdir(parents=True)
    cv2.imwrite(str(tmp_path / "data" / "backgrounds" / "a.png"),
                np.full((64, 64, 3), 90, np.uint8))
    bad = tmp_path / "bad.safetensors"
    bad.write_bytes(b"not weights")
    for extra in (["--data", str(tmp_path / "missing")],
                  ["--data", str(tmp_path / "data"), "--init", str(bad)]):
        assert main(["fmg", "train", "--out", str(tmp_path / "run"), "--iters", "1",
                     "--size", "64", "--batch", "1", *extra]) == 2
        err = capsys.readouterr().err
        assert "Traceback" not in err and err.strip().splitlines()[-1].startswith("error:")
        assert not (tmp_path / "run").exists()


def test_negative_fractions_counts_marks_on_flare_free_composites(tmp_path, monkeypatch):
    """`fmg eval --negatives`: every composite is flare-free with the named negative painted,
    so a network that marks everything scores 100 % and one that marks nothing 0 %."""
    import torch

    import pipeline.fmg_data as fd
    from workflows.research import fmg_eval

    painted = []

    real = fd.add_hard_negatives
    monkeypatch.setattr(fd, "add_hard_negatives",
                        lambda img, rng, kinds: painted.append(kinds) or real(img, rng, kinds))
    monkeypatch.setattr(fmg_eval, "_part_backgrounds",
                        lambda data, size, split: [np.full((80, 80, 3), 90, np.uint8)])

    class Const(torch.nn.Module):
        def __init__(self, v):
            super().__init__()
            self.v = torch.nn.Parameter(torch.tensor(float(v)))

        def forward(self, x):
            return self.v.expand(x.shape[0], 1, *x.shape[2:])

    for logit, want in ((20.0, 1.0), (-20.0, 0.0)):
        monkeypatch.setattr("pipeline.mask.load_fmg_weights", lambda p, c=Const(logit): c)
        monkeypatch.setattr(fmg_eval, "weights_info", lambda p: {"cut": 0.5})
        res = fmg_eval.negative_fractions(tmp_path / "w.safetensors", tmp_path,
                                          ("backlit", "lamp"), count=3, size=32)
        assert set(res["negatives"]) == {"backlit", "lamp"}
        for r in res["negatives"].values():
            assert r["mean"] == want and r["over_1pct"] == (3 if want else 0)
    assert painted.count(("backlit",)) == 6 and painted.count(("lamp",)) == 6
    assert "| backlit | 3 | 0.00 %" in fmg_eval.format_negatives(res)


def test_fmg_eval_clean_with_pads_keeps_what_the_padded_runs_agree_on(tmp_path):
    """`fmg eval --clean --pads`: each clean photo's marks are the pixels every padded run
    marks (the mask stage's default), with --pads-keep regions the plain run's regions they
    agree on, a subset of the plain run's; the paddings are recorded."""
    import cv2

    from pipeline.mask import fmg_probs_pair, regions_touching
    from workflows.research.fmg_eval import clean_fractions, weights_info

    torch.manual_seed(5)
    weights = save_fmg(tmp_path / "w.safetensors", build_fmg(tiny_config()))
    rng = np.random.default_rng(0)
    (tmp_path / "scenes" / "s").mkdir(parents=True)
    for i in range(2):
        img = cv2.GaussianBlur(rng.integers(0, 255, (48, 64, 3), dtype=np.uint8), (9, 9), 3)
        cv2.imwrite(str(tmp_path / "scenes" / "s" / f"p{i}.png"), img)
    cut = weights_info(weights)["cut"]
    pads = ("reflect", "constant")
    got = {p: clean_fractions(weights, tmp_path, 64, scenes=("scenes/s",), pads=p,
                              pads_keep="regions") for p in ((), pads)}
    assert got[pads]["pads"] == list(pads) and got[()]["pads"] == []
    assert got[pads]["pads_keep"] == "regions" and got[()]["pads_keep"] is None
    pixels = clean_fractions(weights, tmp_path, 64, scenes=("scenes/s",), pads=pads)
    from pipeline.mask import load_fmg_weights

    model = load_fmg_weights(weights)
    for i in range(2):
        img = cv2.imread(str(tmp_path / "scenes" / "s" / f"p{i}.png"))
        plain, agreed = fmg_probs_pair(model, [img], 64, (1.0,), pads)
        want = regions_touching(plain[0] > cut, agreed[0] > cut).mean()
        per_view = got[pads]["scenes"]["scenes/s"]["per_view"]
        assert per_view[f"p{i}.png"] == pytest.approx(want)
        assert per_view[f"p{i}.png"] <= got[()]["scenes"]["scenes/s"]["per_view"][f"p{i}.png"]
        assert pixels["scenes"]["scenes/s"]["per_view"][f"p{i}.png"] == pytest.approx(
            (agreed[0] > cut).mean())


def test_fmg_eval_runs_the_one_score_its_options_ask_for(tmp_path, monkeypatch):
    """`run_eval` checks every weights file first, then runs exactly the score its mode
    names with the options that mode takes, and prints that score's table."""
    from dataclasses import replace

    from pipeline.errors import UserError
    from workflows.research import fmg_eval

    weights, loo = tmp_path / "all.safetensors", tmp_path / "no_ghosts.safetensors"
    for path in (weights, loo):
        save_fmg(path, build_fmg(tiny_config()))
    calls = []

    def recorder(name):
        def score(*args, **kwargs):
            calls.append((name, args, kwargs))
            return {"mode": name}
        return score

    modes = ("work_size_sweep", "clean_fractions", "negative_fractions", "evaluate_kinds",
             "evaluate")
    for name in modes:
        monkeypatch.setattr(fmg_eval, name, recorder(name))
    for fmt in ("format_work_sizes", "format_clean", "format_negatives", "format_kinds",
                "format_metrics"):
        monkeypatch.setattr(fmg_eval, fmt, lambda m, fmt=fmt: f"{fmt}:{m['mode']}")
    base = fmg_eval.FMGEvalConfig(weights=weights, data=tmp_path, count=3, size=64)
    cases = [
        (replace(base, work_sizes=(256, 384)), "work_size_sweep", "format_work_sizes"),
        (replace(base, clean=True, rays=True, pads=("reflect",), work_size=320),
         "clean_fractions", "format_clean"),
        (replace(base, negatives=("lamp", "sky")), "negative_fractions", "format_negatives"),
        (replace(base, per_kind=True, loo=(loo,), night=0.0), "evaluate_kinds",
         "format_kinds"),
        (base, "evaluate", "format_metrics"),
    ]
    for cfg, mode, fmt in cases:
        calls.clear()
        metrics, table, used = fmg_eval.run_eval(cfg)
        assert [c[0] for c in calls] == [mode]
        assert metrics == {"mode": mode} and table == f"{fmt}:{mode}" and used == weights
    fmg_eval.run_eval(cases[1][0])
    _, args, kwargs = calls[-1]
    assert args[2] == 320 and kwargs["rays"] and kwargs["pads"] == ("reflect",)
    assert kwargs["confirm_keep"] == "both"  # the default when --confirm-keep is left out
    fmg_eval.run_eval(cases[3][0])
    _, args, kwargs = calls[-1]
    assert args[2] == (loo,) and args[3] == 3 and kwargs["night"] == 0.0
    # a missing leave-one-kind-out file stops the run before any score
    calls.clear()
    with pytest.raises(UserError):
        fmg_eval.run_eval(replace(cases[3][0], loo=(tmp_path / "missing.safetensors",)))
    with pytest.raises(UserError):  # two modes at once
        fmg_eval.run_eval(replace(base, clean=True, per_kind=True))
    assert calls == []
