"""Exploration (fifty-first session): a small per-scene CNN that refines the video's frames.

    python benchmarks/refine_sim.py SYNTH --work DIR --arm NAME --seed S --loo DIR \
        [--iters 600] [--crop 96] [--width 32] [--no-align] --out JSON

The idea: the frames between photos are soft where GN-FR decides them
(``fill_regions_heldout_s50.json``), and the scene's own photos are the only sharp truth at
hand. Render every training camera left out (``benchmarks/novel_loo.py SYNTH --ws ARM_WS
--frames LOO``: neither its photo nor GN-FR's sources see it), teach a small residual U-Net
to turn those renders into the user's photos (outside their flare masks, dilated by 4 px),
then run it on the held-out cameras' frames (``ARM_WS/renders/heldout_cameras``) and score
both against the clean truth as ``eval`` does.

The photos were taken at their cameras' own exposures and a novel frame is rendered at its
nearest sources' (``pipeline/exposure.py``); with ``--align`` (the default) each photo is
first brought to its render's exposure (one gain per channel, the median linear ratio on the
clear pixels), so the refiner learns detail, not the exposures of a few photos.

Nothing in the product uses this: it is the measurement behind docs/history/fill.md, "A
per-scene refiner of the frames, explored".
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

DILATE = 9
"""The flare mask is dilated by this square (px) before its pixels leave the loss."""
BATCH = 8
LR = 1e-3


def refiner(width: int):
    """A residual U-Net of two scales below the frame's; its last layer starts at zero, so an
    untrained refiner returns its input."""
    import torch
    import torch.nn.functional as F
    from torch import nn

    def block(cin, cout, stride=1):
        return nn.Sequential(nn.Conv2d(cin, cout, 3, stride, 1), nn.ReLU(),
                             nn.Conv2d(cout, cout, 3, 1, 1), nn.ReLU())

    class Refiner(nn.Module):
        def __init__(self):
            super().__init__()
            c = width
            self.e1, self.e2, self.e3 = block(3, c), block(c, 2 * c, 2), block(2 * c, 2 * c, 2)
            self.d2 = nn.Sequential(nn.Conv2d(4 * c, 2 * c, 3, 1, 1), nn.ReLU())
            self.d1 = nn.Sequential(nn.Conv2d(3 * c, c, 3, 1, 1), nn.ReLU())
            self.out = nn.Conv2d(c, 3, 3, 1, 1)
            nn.init.zeros_(self.out.weight)
            nn.init.zeros_(self.out.bias)

        def forward(self, x):
            a = self.e1(x)
            b = self.e2(a)
            u = F.interpolate(self.e3(b), size=b.shape[-2:], mode="bilinear")
            u = self.d2(torch.cat([u, b], 1))
            u = F.interpolate(u, size=a.shape[-2:], mode="bilinear")
            return x + self.out(self.d1(torch.cat([u, a], 1)))

    return Refiner()


def to_tensor(bgr: np.ndarray):
    import torch

    return torch.from_numpy(bgr[..., ::-1].copy()).permute(2, 0, 1)[None].float() / 255


def to_bgr(t) -> np.ndarray:
    rgb = t.clamp(0, 1)[0].permute(1, 2, 0).numpy()[..., ::-1]
    return (rgb * 255 + 0.5).astype(np.uint8)


def align_exposure(photo: np.ndarray, render: np.ndarray, clear: np.ndarray) -> np.ndarray:
    """``photo`` (uint8 sRGB) brought to ``render``'s exposure: one gain per channel, the
    median linear ratio over ``clear`` pixels that are neither near black nor clipped."""
    from pipeline.colour import linear_to_srgb, srgb_to_linear

    p = srgb_to_linear(photo.astype(np.float32) / 255)
    r = srgb_to_linear(render.astype(np.float32) / 255)
    ok = clear & (p.max(-1) < 0.9) & (p.min(-1) > 0.005) & (r.min(-1) > 0.005)
    if ok.sum() < 100:
        return photo
    gain = np.exp(np.median(np.log(r[ok] / p[ok]), axis=0))
    return np.clip(linear_to_srgb(p * gain) * 255 + 0.5, 0, 255).astype(np.uint8)


def pairs(scene, ws, loo: Path, align: bool):
    """(render, photo, weight) tensors of every training camera: the left-out render, the
    user's photo at its size, 1 where the photo is clear of its (dilated) flare mask."""
    import cv2
    import torch

    from pipeline.ws_files import read_mask
    from workflows.research.eval.scoring import read_bgr

    out = []
    for s in scene.train:
        x = read_bgr(loo / f"{s}.png")
        h, w = x.shape[:2]
        y = read_bgr(ws.images / f"{s}.png", (h, w))
        m = cv2.dilate(read_mask(ws, s, (w, h)).astype(np.uint8),
                       np.ones((DILATE, DILATE), np.uint8)) == 0
        if align:
            y = align_exposure(y, x, m)
        out.append((to_tensor(x), to_tensor(y), torch.from_numpy(m)[None, None].float()))
    return out


def train(data, iters: int, crop: int, width: int, seed: int):
    """The refiner fitted on random crops (and flips) of ``data``, masked L1, Adam with a
    cosine schedule."""
    import torch

    torch.manual_seed(seed)
    rng = np.random.default_rng(seed)
    net = refiner(width)
    opt = torch.optim.Adam(net.parameters(), LR)
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, iters)
    for _ in range(iters):
        xs, ys, ms = [], [], []
        for _ in range(BATCH):
            x, y, m = data[rng.integers(len(data))]
            r0, c0 = rng.integers(x.shape[-2] - crop), rng.integers(x.shape[-1] - crop)
            crops = [t[..., r0:r0 + crop, c0:c0 + crop] for t in (x, y, m)]
            if rng.random() < 0.5:
                crops = [t.flip(-1) for t in crops]
            for lst, t in zip((xs, ys, ms), crops, strict=True):
                lst.append(t)
        x, y, m = (torch.cat(t) for t in (xs, ys, ms))
        loss = ((net(x) - y).abs() * m).sum() / (3 * m.sum() + 1)
        opt.zero_grad()
        loss.backward()
        opt.step()
        sched.step()
    return net.eval()


def score_heldout(net, scene, held: Path) -> dict:
    """PSNR / SSIM of each held-out frame in ``held`` (``<stem>.png``) against the clean
    truth, as rendered (``base``) and refined by ``net`` (``refined``), per view."""
    import torch

    from pipeline import metrics
    from workflows.research.eval.scoring import read_bgr

    per = {}
    with torch.no_grad():
        for s in scene.heldout:
            x = read_bgr(held / f"{s}.png")
            gt = read_bgr(scene.root / "clean" / f"{s}.png", x.shape[:2])
            r = to_bgr(net(to_tensor(x)))
            per[s] = {"base": {"psnr": metrics.psnr(x, gt), "ssim": metrics.ssim(x, gt)},
                      "refined": {"psnr": metrics.psnr(r, gt), "ssim": metrics.ssim(r, gt)}}
    return per


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", type=Path)
    ap.add_argument("--work", type=Path, required=True, help="folder of the arms' workspaces")
    ap.add_argument("--arm", required=True)
    ap.add_argument("--seed", type=int, required=True)
    ap.add_argument("--loo", type=Path, required=True,
                    help="novel_loo.py --frames folder of this arm's left-out renders")
    ap.add_argument("--iters", type=int, default=600)
    ap.add_argument("--crop", type=int, default=96)
    ap.add_argument("--width", type=int, default=32)
    ap.add_argument("--no-align", dest="align", action="store_false")
    ap.add_argument("--out", type=Path, required=True)
    a = ap.parse_args(argv)
    from workflows.threads import apply_thread_policy

    apply_thread_policy()
    from pipeline.provenance import write_result
    from pipeline.workspace import Workspace
    from workflows.research.eval.scene import load_synth

    scene = load_synth(a.scene)
    ws_dir = a.work / f"{a.scene.name.removesuffix('_synth')}_{a.arm}_s{a.seed}.ws"
    held = ws_dir / "renders" / "heldout_cameras"
    missing = [p for p in (held, *(a.loo / f"{s}.png" for s in scene.train)) if not p.exists()]
    if missing:
        print(f"error: {missing[0]} is missing: run the arm, then novel_loo.py --ws "
              f"{ws_dir} --frames {a.loo}", file=sys.stderr)
        return 2
    t0 = time.time()
    net = train(pairs(scene, Workspace(ws_dir), a.loo, a.align), a.iters, a.crop, a.width, 0)
    train_s = time.time() - t0
    per = score_heldout(net, scene, held)
    mean = {k: {m: float(np.mean([v[k][m] for v in per.values()])) for m in ("psnr", "ssim")}
            for k in ("base", "refined")}
    rec = {"scene": str(a.scene), "workspace": str(ws_dir), "loo": str(a.loo),
           "iters": a.iters, "crop": a.crop, "width": a.width, "align": a.align,
           "train_views": scene.train, "train_seconds": round(train_s, 1),
           "mean": mean, "gain": {m: mean["refined"][m] - mean["base"][m]
                                  for m in ("psnr", "ssim")}, "views": per}
    print(f"{a.scene.name} s{a.seed}: {mean['base']['psnr']:.3f} -> "
          f"{mean['refined']['psnr']:.3f} dB, SSIM {rec['gain']['ssim']:+.4f}, "
          f"trained {train_s:.0f} s", flush=True)
    write_result(a.out, rec)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
