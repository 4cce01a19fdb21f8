"""`deflare-scene eval-llff`: the LLFF split, the ground-truth workspace, results with
provenance read from the checkpoint."""

from __future__ import annotations

import json
import math

import cv2
import numpy as np
import pytest
import torch

from pipeline.cameras import load_cameras
from pipeline.provenance import sha256
from pipeline.training_scenes import load_llff
from tests.conftest import shared
from tests.pipeline.test_llff import _look_at
from workflows.cli import main
from workflows.research.eval_llff import llff_split, posed_workspace

H0, W0, F0 = 120, 160, 150.0
"""Full-size camera of the synthetic scene; images_2 holds 80x60."""


pytestmark = pytest.mark.usefixtures("one_torch_thread")


def _llff_folder(folder, n: int = 10, factor: int = 2):
    """An LLFF folder of ``n`` forward-facing cameras on a 2-row grid looking at a textured
    plane (images rendered by a homography, so views agree). poses_bounds.npy follows
    LLFF's definition: camera-to-world columns down, right, back, then centre and [H, W, f]."""
    rng = np.random.default_rng(0)
    tex = cv2.resize(rng.integers(0, 255, (24, 32, 3), dtype=np.uint8), (320, 240),
                     interpolation=cv2.INTER_CUBIC)
    h, w = H0 // factor, W0 // factor
    K = np.array([[F0 / factor, 0, w / 2], [0, F0 / factor, h / 2], [0, 0, 1]])
    # plane z = 0, x in [-2, 2], y in [-1.5, 1.5] -> texture pixels
    A = np.array([[80.0, 0, 160], [0, 80.0, 120], [0, 0, 1]])
    rows = []
    (folder / f"images_{factor}").mkdir(parents=True)
    for i in range(n):
        centre = np.array([-0.5 + (i % 5) * 0.25, -0.2 + (i // 5) * 0.4, -4.0])
        c2w = _look_at(centre, np.zeros(3))
        w2c = np.linalg.inv(c2w)
        Hm = K @ w2c[:3][:, [0, 1, 3]] @ np.linalg.inv(A)  # texture -> image
        img = cv2.warpPerspective(tex, Hm, (w, h), borderMode=cv2.BORDER_REFLECT)
        cv2.imwrite(str(folder / f"images_{factor}" / f"v{i:02d}.png"), img)
        R = c2w[:3, :3]
        llff = np.stack([R[:, 1], R[:, 0], -R[:, 2], c2w[:3, 3], [H0, W0, F0]], 1)
        rows.append(np.concatenate([llff.reshape(-1), [3.0, 5.5]]))
    np.save(folder / "poses_bounds.npy", np.array(rows))
    return folder


def test_split_holds_out_every_8th_view():
    stems = [f"IMG_{i:04d}" for i in range(20)]
    train, held = llff_split(stems, 8)
    assert held == ["IMG_0000", "IMG_0008", "IMG_0016"]
    assert train == [s for s in stems if s not in held] and len(train) == 17


def test_eval_llff_end_to_end_records_provenance(tmp_path):
    folder = _llff_folder(tmp_path / "toy")
    out = tmp_path / "ev"
    args = ["eval-llff", str(folder), "--out", str(out), "--preset", "tiny", "--iters", "5",
            "--device", "cpu", "--init", "scratch"]
    assert main(args) == 0
    res = json.loads((out / "results.json").read_text())
    assert res["heldout_views"] == ["v00", "v08"]
    assert res["train_views"] == [f"v{i:02d}" for i in range(10) if i not in (0, 8)]
    # the evaluation workspace has load_llff's cameras, pinhole, images = decoded
    sc = load_llff(folder)
    cams = load_cameras(out / "posed" / "cameras.json")
    assert cams.stems == sc.stems
    for i, f in enumerate(cams.frames):
        assert np.allclose(f.K, sc.K[i].numpy()) and np.allclose(f.c2w, sc.c2w[i].numpy())
        assert f.near == pytest.approx(float(sc.near[i]))
        assert f.far == pytest.approx(float(sc.far[i]))
        assert f.colmap_camera["model"] == "PINHOLE" and (f.width, f.height) == (80, 60)
    train_cams = load_cameras(out / "clean.ws" / "cameras.json")
    assert train_cams.stems == res["train_views"]  # held-out views never seen in training
    # one scored render per fill, at full size, of exactly the held-out views
    clean = res["clean"]
    assert set(clean["methods"]) == {"gnfr_hybrid", "gnfr_network"}
    for m in clean["methods"].values():
        assert set(m["heldout"]["views"]) == {"v00", "v08"}
        assert math.isfinite(m["heldout"]["psnr"]) and 0 < m["heldout"]["ssim"] < 1
        for s in ("v00", "v08"):
            img = cv2.imread(f"{m['renders']}/{s}.png")
            assert img.shape == (60, 80, 3)
    # provenance: code and machine of the scoring run, and what trained the model, read
    # from the checkpoint itself
    prov = clean["provenance"]
    assert prov["machine"]["cpu"] and prov["machine"]["torch"] == torch.__version__
    assert "commit" in prov["code"] and "dirty" in prov["code"]
    assert prov["masks"]["source"].startswith("masks:")
    mp = clean["methods"]["gnfr_hybrid"]["provenance"]
    ckpt = out / "clean.ws" / "variants" / "gnfr" / "model" / "gnfr.safetensors"
    assert mp["checkpoint_sha256"] == sha256(ckpt)
    trained = mp["trained"]
    assert trained["init"] == {"init": "scratch", "weights": "scratch", "sha256": None}
    assert trained["steps_done"] == 5 and trained["train"]["iters"] == 5
    assert trained["preset"] == "tiny" and trained["seed"] == 0
    assert trained["device"] == "cpu" and trained["train_seconds"] > 0
    assert sorted(mp["summary"]["heldout_fill"]) == ["hybrid", "network"]
    assert sorted(mp["renders"]) == ["render:heldout_hybrid", "render:heldout_network"]
    table = (out / "table.md").read_text()
    assert res["published"] == [] and "(published)" not in table  # fern's only, not toy's
    # a second model started from the first: its start file and hash come from its own
    # checkpoint, not from the options of the scoring run
    out2 = tmp_path / "ev2"
    args2 = [*args[:-1], str(ckpt)]
    args2[args2.index("--out") + 1] = str(out2)
    assert main(args2) == 0
    res2 = json.loads((out2 / "results.json").read_text())
    init = res2["clean"]["methods"]["gnfr_network"]["provenance"]["trained"]["init"]
    assert init["sha256"] == sha256(ckpt) and init["weights"] == str(ckpt.resolve())
    assert init["metadata"]["step"] == 5


def test_fern_split_and_ground_truth_workspace(tmp_path):
    fern = shared("scenes", "fern")
    ws = posed_workspace(fern, tmp_path / "posed", 504)
    cams = load_cameras(ws.cameras_json)
    train, held = llff_split(cams.stems, 8)
    assert held == ["IMG_4026", "IMG_4034", "IMG_4042"] and len(train) == 17
    assert {(f.width, f.height) for f in cams.frames} == {(504, 378)}
    img = cv2.imread(str(ws.images / "IMG_4026.png"))
    src = cv2.imread(str(fern / "images_8" / "IMG_4026.png"))
    assert np.array_equal(img, src)  # images_8 is 504x378: copied unchanged


def test_docs_fern_rows_match_their_results_file():
    """docs/history/eval.md quotes docs/results/fern_llff_quick_cpu.json: no drift."""
    from tests.conftest import REPO

    res = json.loads((REPO / "docs/results/fern_llff_quick_cpu.json").read_text())
    doc = (REPO / "docs/history/eval.md").read_text()
    for fill in ("hybrid", "network"):
        h = res["clean"]["methods"][f"gnfr_{fill}"]["heldout"]
        row = f"| GN-FR quick, fill {fill} (this project) | {h['psnr']:.2f} | {h['ssim']:.3f} |"
        assert row in doc, row
    if "flare" in res:
        for name, m in res["flare"]["methods"].items():
            i, h = m["inputs"], m.get("heldout") or {}
            psnr = "—" if h.get("psnr") is None else f"{h['psnr']:.2f}"
            row = f"| {m['label']} | {i['psnr_flare']:.2f} | {i['psnr']:.2f} | {psnr} |"
            assert row in doc, (name, row)
