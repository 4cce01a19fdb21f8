"""Provenance: the code version, and what finetune writes into its checkpoint."""

from __future__ import annotations

import re
from dataclasses import replace

import torch

from gnfr.checkpoint import read_metadata
from pipeline.finetune import checkpoint_provenance, fit
from pipeline.provenance import code_version, machine, sha256
from pipeline.training_scenes import load_workspace
from tests.fixtures import make_temple_workspace
from tests.pipeline.test_finetune import TINY


def test_code_version_names_commit_and_dirty_files():
    v = code_version()
    assert v["commit"] is None or re.fullmatch(r"[0-9a-f]{40}", v["commit"])
    if v["commit"] is not None:
        assert v["dirty"] == bool(v["dirty_files"])
        assert (v["diff_sha256"] is None) == (not v["dirty"])
        assert all(not f.startswith(" ") and f for f in v["dirty_files"])
    m = machine()
    assert m["torch"] == torch.__version__ and m["torch_threads"] == torch.get_num_threads()


def test_checkpoint_records_its_start_and_keeps_it_across_a_resume(tmp_path):
    ws = make_temple_workspace(tmp_path / "ws", n_views=5, scale=0.2)
    scene = load_workspace(ws.root)
    cpu = torch.device("cpu")
    fit(scene, replace(TINY, iters=5), cpu, tmp_path / "first", resume=False, init="scratch")
    start = tmp_path / "first" / "gnfr.safetensors"
    assert checkpoint_provenance(start)["init"]["weights"] == "scratch"
    cfg = replace(TINY, iters=10, seed=3, ckpt_every=5)
    fit(scene, replace(cfg, iters=5), cpu, tmp_path / "run", resume=False, init=str(start))
    p5 = checkpoint_provenance(tmp_path / "run" / "gnfr.safetensors")
    assert p5["init"]["sha256"] == sha256(start) and p5["init"]["metadata"]["step"] == 5
    assert p5["steps_done"] == 5 and p5["seed"] == 3 and p5["train"]["iters"] == 5
    assert p5["cached_features"] is False and p5["device"] == "cpu"
    # resumed to 10 steps: the start stays the file it began from, seconds add up
    fit(scene, cfg, cpu, tmp_path / "run", resume=True, init="scratch")
    p10 = checkpoint_provenance(tmp_path / "run" / "gnfr.safetensors")
    assert p10["init"] == p5["init"] and p10["started"] == p5["started"]
    assert p10["steps_done"] == 10 and p10["train_seconds"] > p5["train_seconds"]
    assert [r["at_step"] for r in p10["resumed"]] == [5]
    assert read_metadata(tmp_path / "run" / "gnfr.safetensors")[1]["step"] == 10
