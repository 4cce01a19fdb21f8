"""Benchmark: does pretraining help fine-tuning on the held-out sample scene?

Fine-tune the quick preset on the held-out sample scene from the shipped weights and from
scratch at equal steps; training-ray PSNR and held-out-view PSNR.

    python benchmarks/pretrain_eval.py --out /tmp/cyx --iters 500

The workspace is built from ``samples/cyprus`` (8 flared photos) with the ground-truth
cameras, masks and clean images of ``samples/cyprus_truth`` (photos undistorted to the
ground-truth pinhole cameras), so the two held-out cameras are in the training frame and no
SfM error enters the comparison. Held-out views are rendered in full (no flare blend) at
``--render-scale`` of their size and scored against the clean ground truth (every pixel,
and the flare region of their ground-truth mask). One JSON line per variant.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code
from workflows.threads import apply_thread_policy

apply_thread_policy()  # before torch loads (workflows/threads.py)

import cv2  # noqa: E402
import numpy as np  # noqa: E402
import torch  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
TRUTH = REPO / "samples" / "cyprus_truth"


def undistort(img: np.ndarray, frame: dict, nearest: bool = False) -> np.ndarray:
    """Decoded-framing image (SIMPLE_RADIAL colmap camera) -> the frame's pinhole image."""
    cc = frame["colmap_camera"]
    f, cx, cy, k1 = cc["params"]
    if (img.shape[1], img.shape[0]) != (cc["width"], cc["height"]):
        img = cv2.resize(img, (cc["width"], cc["height"]), interpolation=cv2.INTER_AREA)
    Kd = np.array([[f, 0, cx], [0, f, cy], [0, 0, 1.0]])
    m1, m2 = cv2.initUndistortRectifyMap(Kd, np.array([k1, 0, 0, 0.0]), None,
                                         np.array(frame["K"]), (frame["width"],
                                                                frame["height"]),
                                         cv2.CV_32FC1)
    return cv2.remap(img, m1, m2, cv2.INTER_NEAREST if nearest else cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_REPLICATE)


def build_workspace(root: Path) -> Path:
    """Posed, masked, selected workspace of the 8 training views (ground-truth cameras)."""
    from pipeline import mask, select
    from pipeline.cameras import Cameras, Frame
    from pipeline.images import read_gray, read_image
    from pipeline.workspace import Workspace, atomic_imwrite
    from pipeline.ws_files import write_cameras

    gt = json.loads((TRUTH / "cameras_gt.json").read_text())
    train = json.loads((TRUTH / "split.json").read_text())["train"]
    frames = {f["stem"]: f for f in gt["frames"]}
    ws = Workspace.create(root, REPO / "samples" / "cyprus")
    if (ws.views_json).exists():
        return root
    mdir = root.parent / (root.name + "_masks")
    mdir.mkdir(exist_ok=True)
    out = []
    for s in train:
        fr = frames[s]
        img = undistort(read_image(REPO / "samples" / "cyprus" / f"{s}.jpg", bgr=True), fr)
        atomic_imwrite(ws.image_path(s), img)
        atomic_imwrite(ws.decoded_path(s), img)
        m = undistort(read_gray(TRUTH / "masks_gt" / f"{s}.png"), fr, nearest=True)
        cv2.imwrite(str(mdir / f"{s}.png"), m)
        W, H = fr["width"], fr["height"]
        K = np.array(fr["K"])
        out.append(Frame(name=fr["name"], stem=s, K=K, width=W, height=H,
                         c2w=np.array(fr["c2w"]), near=fr["near"], far=fr["far"],
                         colmap_camera={"model": "PINHOLE", "width": W, "height": H,
                                        "params": [K[0, 0], K[1, 1], K[0, 2], K[1, 2]]}))
    write_cameras(ws, Cameras(frames=out, colmap_to_world=np.array(gt["colmap_to_world"])))
    for stage, outs in (("decode", [ws.decoded]), ("pose", [ws.images, ws.cameras_json])):
        ws.record_stage(stage, {"pretrain_eval": "gt cameras"}, outs)
    mask.run(replace(mask.MaskConfig(), masks_dir=mdir), ws)
    select.run(select.SelectConfig(), ws)
    return root


def render_heldout(model_path: Path, scene, scale: float) -> dict:
    """PSNR of the 2 held-out views rendered from the 8 training views."""
    from gnfr.checkpoint import load_model, read_metadata
    from gnfr.geometry import image_pixels, pixel_rays
    from gnfr.renderer import SourceViews, render_rays
    from gnfr.train import downscale
    from gnfr.view_sampler import eval_sources
    from pipeline.images import read_gray, read_image
    from pipeline.metrics import masked_psnr, psnr
    from pipeline.ws_files import MASK_THRESHOLD

    _, meta = read_metadata(model_path)
    model = load_model(model_path)
    imgs, K, masks, _ = downscale(scene, meta["source_scale"])
    src = SourceViews.encode(model, imgs, K, scene.c2w.float(), masks, "cpu")
    gt = {f["stem"]: f for f in json.loads((TRUTH / "cameras_gt.json").read_text())["frames"]}
    res = {}
    for s in json.loads((TRUTH / "split.json").read_text())["heldout"]:
        fr = gt[s]
        W, H = round(fr["width"] * scale), round(fr["height"] * scale)
        Kc = torch.tensor(fr["K"], dtype=torch.float32)
        Kc[:2] *= torch.tensor([[W / fr["width"]], [H / fr["height"]]])
        c2w = torch.tensor(fr["c2w"], dtype=torch.float32)
        d = (scene.c2w[:, :3, 3].float() - c2w[:3, 3]).norm(dim=1)
        ranked = [scene.stems[i] for i in d.argsort().tolist()]
        ids = torch.tensor([scene.stems.index(x) for x in
                            eval_sources(ranked, scene.flare, meta["eval_views"])])
        o, dd = pixel_rays(Kc, c2w, image_pixels(H, W))
        n = o.shape[0]
        out = render_rays(model, src, ids, o, dd, torch.full((n,), fr["near"]),
                          torch.full((n,), fr["far"]), meta["samples"])
        pred = out["rgb"].reshape(H, W, 3).numpy()
        clean = undistort(read_image(TRUTH / "clean" / f"{s}.png"), fr)
        clean = cv2.resize(clean, (W, H), interpolation=cv2.INTER_AREA) / 255.0
        fm = undistort(read_gray(TRUTH / "masks_gt" / f"{s}.png"), fr, nearest=True)
        fm = cv2.resize(fm, (W, H), interpolation=cv2.INTER_NEAREST) > MASK_THRESHOLD
        res[s] = {"psnr": round(psnr(pred, clean), 2),
                  "psnr_flare_region": round(masked_psnr(pred, clean, fm) or 0.0, 2)}
        cv2.imwrite(str(model_path.with_name(f"{model_path.stem}_heldout_{s}.png")),
                    cv2.cvtColor(np.uint8(pred * 255 + 0.5), cv2.COLOR_RGB2BGR))
    return res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("/tmp/cyx"))
    ap.add_argument("--iters", type=int, default=500)
    ap.add_argument("--variant", default="all",
                    help="zero-shot | pretrained-cached | pretrained-e2e | scratch | all")
    ap.add_argument("--weights", type=Path, default=REPO / "gnfr" / "weights" /
                    "gnfr.safetensors")
    ap.add_argument("--render-scale", type=float, default=0.5)
    a = ap.parse_args()
    from gnfr.train import QUICK
    from pipeline.finetune import fit
    from pipeline.training_scenes import load_workspace
    from pipeline.workspace import MODEL_FILE  # fit writes a WS/model-like folder

    root = build_workspace(a.out / "ws")
    scene = load_workspace(root)
    if a.variant in ("all", "zero-shot"):  # the shipped weights without fine-tuning
        print(json.dumps({"variant": "zero-shot", "iters": 0,
                          "heldout": render_heldout(a.weights, scene, a.render_scale)}),
              flush=True)
    variants = {"pretrained-cached": (str(a.weights), True),
                "pretrained-e2e": (str(a.weights), False), "scratch": ("scratch", False)}
    for name, (init, cached) in variants.items():
        if a.variant not in ("all", name):
            continue
        cfg = replace(QUICK, iters=a.iters, cached_features=cached)
        out = a.out / name
        t0, c0 = time.time(), time.process_time()
        fit(scene, cfg, torch.device("cpu"), out, resume=True, init=init, preset="quick")
        wall, cpu = time.time() - t0, time.process_time() - c0
        m = [json.loads(x) for x in (out / "metrics.jsonl").read_text().splitlines()]
        curve = {r["step"]: round(r["psnr"], 2) for r in m}
        print(json.dumps({"variant": name, "iters": a.iters, "train_wall_s": round(wall),
                          "train_cpu_s": round(cpu), "load": round(os.getloadavg()[0], 1),
                          "train_psnr": curve,
                          "heldout": render_heldout(out / MODEL_FILE, scene,
                                                    a.render_scale)}), flush=True)


if __name__ == "__main__":
    main()
