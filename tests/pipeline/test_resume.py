"""Stages killed part-way resume where they stopped: pose keeps its database, mask its files."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pipeline.workspace import Workspace
from tests.conftest import shared
from tests.pipeline.test_mask_select import make_kermit_ws
from workflows.cli import main


def _status(ws: Workspace, stage: str) -> str:
    return json.loads((ws.root / "manifest.json").read_text())["stages"][stage]["status"]


def test_pose_killed_while_matching_resumes_with_its_database(tmp_path, monkeypatch):
    pycolmap = pytest.importorskip("pycolmap")
    out = tmp_path / "kermit.deflare"
    assert main(["decode", str(shared("scenes", "kermit")), "--out", str(out),
                 "--max-size", "400"]) == 0
    real_match = pycolmap.match_exhaustive

    def killed(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(pycolmap, "match_exhaustive", killed)
    assert main(["pose", str(out), "--threads", "1"]) == 130  # Ctrl-C's exit code
    ws = Workspace.open(out)
    db = ws.colmap / "database.db"
    assert _status(ws, "pose") == "running" and db.is_file()
    before = db.stat().st_ino
    database = pycolmap.Database.open(str(db))
    images = {im.name: im.image_id for im in database.read_all_images()}
    kp = {n: database.read_keypoints(i).copy() for n, i in images.items()}
    database.close()
    assert len(images) == 11 and all(len(k) > 50 for k in kp.values())

    monkeypatch.setattr(pycolmap, "match_exhaustive", real_match)
    assert main(["pose", str(out), "--threads", "1"]) == 0
    assert _status(ws, "pose") == "complete"
    assert db.stat().st_ino == before  # the same database file, not a new one
    database = pycolmap.Database.open(str(db))
    again = {im.name: im.image_id for im in database.read_all_images()}
    same = all(np.array_equal(database.read_keypoints(i), kp[n]) for n, i in again.items())
    database.close()
    assert again == images and same  # no image imported twice, features kept
    report = json.loads((ws.colmap / "report.json").read_text())
    assert report["registered"] >= 8 and ws.cameras_json.is_file()


def test_mask_killed_part_way_writes_only_the_missing_masks(tmp_path, monkeypatch):
    import torch

    import gnfr.fmg as fmg

    ws = make_kermit_ws(tmp_path / "ws", n=6, scale=0.25)
    torch.manual_seed(0)
    weights = fmg.save_fmg(tmp_path / "tiny.safetensors", fmg.build_fmg(fmg.tiny_config()))
    # the network's masks alone (the other photos' judgement rewrites every mask at the end)
    args = ["mask", str(ws.root), "--weights", str(weights), "--batch", "1",
            "--no-ghost-lines"]
    real, calls = fmg.predict_probs_pair, []  # what every run of the network goes through

    def dying(model, images, long_side=None, scales=fmg.SCALES, pads=()):
        if len(calls) == 3:
            raise KeyboardInterrupt
        calls.append(images.shape)
        return real(model, images, long_side, scales, pads)

    monkeypatch.setattr(fmg, "predict_probs_pair", dying)
    assert main(args) == 130
    done = sorted(ws.masks.glob("*.png"))
    assert len(done) == 3 and not list(ws.masks.glob(".*"))  # no half-written file
    assert _status(ws, "mask") == "running" and not ws.flare_json.exists()
    mtimes = {p.name: p.stat().st_mtime_ns for p in done}

    calls.clear()
    monkeypatch.setattr(fmg, "predict_probs_pair",
                        lambda *a, **k: (calls.append(1), real(*a, **k))[1])
    assert main(args) == 0
    assert len(calls) == 3  # only the three missing views went through the network
    assert {p.name: p.stat().st_mtime_ns for p in done} == mtimes
    flare = json.loads(ws.flare_json.read_text())
    assert len(flare["views"]) == 6 and _status(ws, "mask") == "complete"
