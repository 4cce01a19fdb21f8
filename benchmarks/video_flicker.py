"""How much a rendered video jumps between frames: the warping error of each step.

    python benchmarks/video_flicker.py WS/renders/PATH [WS/renders/PATH2 ...] --out FILE.json

For each pair of consecutive frames (a rendered path's PNGs in order) the later frame is
warped back onto the earlier one by OpenCV's DIS optical flow (medium preset, on grey
frames) and the two are compared: the mean absolute difference of their colours (0..1) over
the pixels whose flow passes a forward-backward check (Sundaram et al.'s: the two flows
cancel to within 1 % of their squared lengths plus half a pixel) and lands inside the frame.
Smooth motion warps away; what is left is what changes that motion does not explain: a
frame that pops (its sources changed, a soft patch came and went). This is the temporal
warping error of the video-consistency literature (Lai et al. 2018), measured without any
depth or camera, so it does not share the renderer's geometry.

Per path: the steps' errors, their mean, median, 90th percentile and largest, the spread
(90th percentile over median), and the frames' sharpness (mean Sobel gradient magnitude of
the grey frames, 0..1 units per pixel), which a cross-fade of two renders can lower. With the
path's ``cameras.json`` (the render writes it) each step also says whether the frames'
sources changed there (``sources_changed``). Bad input: one line on stderr, exit 2.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

CONSISTENT = (0.01, 0.5)
"""Forward-backward check: |f + b|^2 < 0.01 (|f|^2 + |b|^2) + 0.5 (pixels^2)."""


def warp_error(a: np.ndarray, b: np.ndarray, dis=None) -> tuple[float, float]:
    """(mean absolute colour difference 0..1, share of pixels compared) between frame ``a``
    and frame ``b`` warped back onto it by DIS flow (uint8 BGR or RGB [H, W, 3] frames of one
    size). No pixel passing the check: (nan, 0)."""
    import cv2

    if dis is None:
        dis = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)
    ga, gb = (cv2.cvtColor(x, cv2.COLOR_BGR2GRAY) for x in (a, b))
    fw, bw = dis.calc(ga, gb, None), dis.calc(gb, ga, None)
    H, W = ga.shape
    gx, gy = np.meshgrid(np.arange(W, dtype=np.float32), np.arange(H, dtype=np.float32))
    mx, my = gx + fw[..., 0], gy + fw[..., 1]
    back = cv2.remap(bw, mx, my, cv2.INTER_LINEAR)
    b_at = cv2.remap(b, mx, my, cv2.INTER_LINEAR).astype(np.float32)
    k, c = CONSISTENT
    ok = ((fw + back) ** 2).sum(-1) < k * ((fw ** 2).sum(-1) + (back ** 2).sum(-1)) + c
    ok &= (mx >= 0) & (mx <= W - 1) & (my >= 0) & (my <= H - 1)
    if not ok.any():
        return float("nan"), 0.0
    diff = np.abs(b_at - a.astype(np.float32)).mean(-1) / 255.0
    return float(diff[ok].mean()), float(ok.mean())


def sharpness(img: np.ndarray) -> float:
    """Mean Sobel gradient magnitude of a frame's grey image (0..1 units per pixel)."""
    import cv2

    g = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY).astype(np.float32) / 255.0
    gx, gy = cv2.Sobel(g, cv2.CV_32F, 1, 0) / 8, cv2.Sobel(g, cv2.CV_32F, 0, 1) / 8
    return float(np.sqrt(gx ** 2 + gy ** 2).mean())


def frames_of(folder: Path) -> list[Path]:
    """A rendered path's PNG frames in order; SystemExit (exit 2) when it has fewer than two
    or they differ in size."""
    folder = Path(folder)
    if not folder.is_dir():
        raise SystemExit(f"{folder}: no such folder (give a rendered path: WS/renders/PATH)")
    files = sorted(folder.glob("*.png"))
    if len(files) < 2:
        raise SystemExit(f"{folder}: fewer than two PNG frames (give a rendered path: "
                         "WS/renders/PATH)")
    return files


def path_flicker(folder: Path) -> dict:
    """The steps' warping errors and the frames' sharpness of one rendered path."""
    import cv2

    files = frames_of(folder)
    dis = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)
    sources = None
    cams = Path(folder) / "cameras.json"
    if cams.is_file():
        frames = json.loads(cams.read_text()).get("frames", [])
        if len(frames) == len(files) and all("sources" in f for f in frames):
            sources = [set(f["sources"]) for f in frames]
    imgs, steps, sharp = [], [], []
    for f in files:
        img = cv2.imread(str(f), cv2.IMREAD_COLOR)
        if img is None:
            raise SystemExit(f"{f}: not a readable PNG (render the path again)")
        if imgs and img.shape != imgs[-1].shape:
            raise SystemExit(f"{f}: not the size of the frame before it (one path per folder)")
        imgs.append(img)
        sharp.append(sharpness(img))
        if len(imgs) == 2:
            e, cover = warp_error(imgs[0], imgs[1], dis)
            step = {"error": round(e, 6), "compared": round(cover, 4)}
            if sources is not None:
                t = len(steps)
                step["sources_changed"] = sources[t] != sources[t + 1]
            steps.append(step)
            imgs.pop(0)
    err = np.array([s["error"] for s in steps], float)
    med = float(np.nanmedian(err))
    p90 = float(np.nanpercentile(err, 90))
    out = {"frames": len(files), "steps": steps,
           "mean": round(float(np.nanmean(err)), 6), "median": round(med, 6),
           "p90": round(p90, 6), "max": round(float(np.nanmax(err)), 6),
           "spread": round(p90 / med, 4) if med > 0 else None,
           "sharpness": round(float(np.mean(sharp)), 6)}
    if sources is not None:
        ch = np.array([s["sources_changed"] for s in steps])
        out["changed_steps"] = int(ch.sum())
        if ch.any():
            out["changed_mean"] = round(float(np.nanmean(err[ch])), 6)
        if (~ch).any():
            out["unchanged_mean"] = round(float(np.nanmean(err[~ch])), 6)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("paths", nargs="+", type=Path, help="rendered path folders (PNG frames)")
    ap.add_argument("--out", type=Path, help="write the results as JSON here")
    a = ap.parse_args(argv)
    try:
        res = {str(p): path_flicker(p) for p in a.paths}
    except SystemExit as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    for p, r in res.items():
        line = (f"{p}: mean {r['mean']:.4f} median {r['median']:.4f} p90 {r['p90']:.4f} "
                f"max {r['max']:.4f} spread {r['spread']} sharpness {r['sharpness']:.4f}")
        if "changed_steps" in r:
            line += f" | sources changed at {r['changed_steps']} steps"
        print(line)
    from pipeline.provenance import write_result

    write_result(a.out, {"paths": res})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
