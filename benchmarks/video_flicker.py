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
the grey frames, 0..1 units per pixel), which a cross-fade of two renders can lower, and
their brightness (mean colour, 0..1; a darker video has smaller errors and gradients). With
the path's ``cameras.json`` (the render writes it) each step also says whether the frames'
sources changed there (``sources_changed``). ``--flow farneback`` warps by Farneback's flow
instead of DIS (a second, independent estimate). Bad input: one line on stderr, exit 2.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

CONSISTENT = (0.01, 0.5)
"""Forward-backward check: |f + b|^2 < 0.01 (|f|^2 + |b|^2) + 0.5 (pixels^2)."""


FLOWS = ("dis", "farneback")
"""The optical flows the warping error can take: OpenCV's DIS (medium preset; the default)
or Farneback's polynomial expansion (a second, independent estimate, so a rule does not
rest on one flow's errors)."""


def flow_calc(kind: str = "dis"):
    """A function (grey a, grey b) -> flow from a to b, of one of ``FLOWS``."""
    import cv2

    if kind == "farneback":
        return lambda ga, gb: cv2.calcOpticalFlowFarneback(ga, gb, None, 0.5, 4, 15, 3, 5,
                                                            1.2, 0)
    if kind != "dis":
        raise ValueError(f"flow {kind!r}: use one of {', '.join(FLOWS)}")
    dis = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)
    return lambda ga, gb: dis.calc(ga, gb, None)


def warp_error(a: np.ndarray, b: np.ndarray, flow=None) -> tuple[float, float]:
    """(mean absolute colour difference 0..1, share of pixels compared) between frame ``a``
    and frame ``b`` warped back onto it by optical flow (``flow``: a :func:`flow_calc`
    function, DIS by default; uint8 BGR or RGB [H, W, 3] frames of one size). No pixel
    passing the check: (nan, 0)."""
    import cv2

    flow = flow or flow_calc()
    ga, gb = (cv2.cvtColor(x, cv2.COLOR_BGR2GRAY) for x in (a, b))
    fw, bw = flow(ga, gb), flow(gb, ga)
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


def exposure_matched(cand: np.ndarray, base: np.ndarray) -> np.ndarray:
    """``cand`` (uint8 frame) at ``base``'s exposure: times the per-channel gain in linear
    light that fits it to ``base`` by least squares. A frame that differs from another by
    a gain alone comes out as it, so its sharpness is the other's; what is clipped stays."""
    from pipeline.exposure import lin_to_srgb, srgb_to_lin

    c = srgb_to_lin(cand.astype(np.float32) / 255.0)
    b = srgb_to_lin(base.astype(np.float32) / 255.0)
    g = (c * b).sum((0, 1)) / np.maximum((c * c).sum((0, 1)), 1e-9)
    return np.clip(np.rint(lin_to_srgb(c * g) * 255.0), 0, 255).astype(np.uint8)


def matched_sharpness(base: Path, cand: Path) -> tuple[float, float]:
    """(the baseline frames' mean sharpness, the candidate's at the baseline's exposure,
    frame by frame: :func:`exposure_matched`): the detail a candidate keeps, whatever
    exposure it renders at."""
    import cv2

    pairs = list(zip(frames_of(base), frames_of(cand), strict=True))
    b = [sharpness(cv2.imread(str(x))) for x, _ in pairs]
    c = [sharpness(exposure_matched(cv2.imread(str(y)), cv2.imread(str(x)))) for x, y in pairs]
    return float(np.mean(b)), float(np.mean(c))


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


def path_flicker(folder: Path, flow: str = "dis") -> dict:
    """The steps' warping errors (by ``flow``, one of ``FLOWS``) and the frames' sharpness
    of one rendered path."""
    import cv2

    files = frames_of(folder)
    calc = flow_calc(flow)
    sources = None
    cams = Path(folder) / "cameras.json"
    if cams.is_file():
        frames = json.loads(cams.read_text()).get("frames", [])
        if len(frames) == len(files) and all("sources" in f for f in frames):
            sources = [set(f["sources"]) for f in frames]
    imgs, steps, sharp, bright = [], [], [], []
    for f in files:
        img = cv2.imread(str(f), cv2.IMREAD_COLOR)
        if img is None:
            raise SystemExit(f"{f}: not a readable PNG (render the path again)")
        if imgs and img.shape != imgs[-1].shape:
            raise SystemExit(f"{f}: not the size of the frame before it (one path per folder)")
        imgs.append(img)
        sharp.append(sharpness(img))
        bright.append(float(img.mean()) / 255.0)
        if len(imgs) == 2:
            e, cover = warp_error(imgs[0], imgs[1], calc)
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
           "sharpness": round(float(np.mean(sharp)), 6),
           "brightness": round(float(np.mean(bright)), 6)}
    if sources is not None:
        ch = np.array([s["sources_changed"] for s in steps])
        out["changed_steps"] = int(ch.sum())
        if ch.any():
            out["changed_mean"] = round(float(np.nanmean(err[ch])), 6)
        if (~ch).any():
            out["unchanged_mean"] = round(float(np.nanmean(err[~ch])), 6)
    return out


RULE = {"largest": -0.15, "largest_builds": 4, "mean": 0.02, "sharpness": -0.02,
        "renders": 1.5}
"""The fifty-third session's rule for ``render --source-fade`` (docs/history/fill.md,
"Changes of a frame's sources cross-faded"): the largest step's error down 15 % on the mean
and on four builds, the mean error up at most 2 %, the sharpness down at most 2 %, at most
1.5 images rendered per frame, each on the mean over the builds."""

HOLD_RULE = {"mean": -0.01, "largest": 0.02, "sharpness": -0.005}
"""The same session's rule for ``render --source-hold`` against the fade alone
(docs/history/fill.md, "A frame's sources held along the path"): the steps' mean error down
1 %, the largest step up at most 2 %, the sharpness down at most 0.5 %, and no more images
rendered per frame, each on the mean over the builds."""


EXPOSURE_RULE = {"mean": -0.02, "largest": 0.02, "brightness": -0.02}
"""The fifty-fourth session's rule for ``render --path-exposure`` against the frames'
sources' median exposure (docs/history/fill.md, "The video's exposure along the path"): the
steps' mean error down 2 % by DIS and by Farneback flow alike, the largest step up at most
2 %, the brightness down at most 2 % (a darker video has smaller errors), each on the mean
over the builds; the frames' sharpness at the baseline's exposure
(:func:`matched_sharpness`) is reported beside it. The rule's fourth part, the left-out
views' fidelity, is ``benchmarks/novel_loo.py``'s."""


CUT_RULE = {"mean": -0.02, "mean_paths": 3, "largest": 0.02, "sharpness": -0.02,
            "renders_ratio": 1.7}
"""The fifty-fifth session's rule for ``render --fade-cut`` against the photos' spacing
alone (docs/history/fill.md, "The cross-fade's cut by the path's own steps"): the steps'
mean error down 2 % on the mean and down on three paths of four, the largest step up at
most 2 %, the sharpness down at most 2 %, at most 1.7 times the baseline's images a frame."""

RULES = {"fade": RULE, "hold": HOLD_RULE, "exposure": EXPOSURE_RULE, "cut": CUT_RULE}


def renders_per_frame(folder: Path) -> float:
    """Images rendered per frame of a path: 1 + its fades (the path's cameras.json; 1
    without one)."""
    if not (Path(folder) / "cameras.json").is_file():
        return 1.0
    frames = json.loads((Path(folder) / "cameras.json").read_text())["frames"]
    return float(np.mean([1 + len(f.get("fades", [])) for f in frames]))


def same_unfaded(base: Path, cand: Path) -> tuple[int, int]:
    """(frames the candidate renders without a fade, how many are the baseline's to the
    bit); every frame without a cameras.json."""
    import cv2

    if (Path(cand) / "cameras.json").is_file():
        frames = json.loads((Path(cand) / "cameras.json").read_text())["frames"]
        plain = [f["name"] for f in frames if not f.get("fades")]
    else:
        plain = [f.stem for f in frames_of(cand)]
    same = sum(np.array_equal(cv2.imread(str(Path(base) / f"{n}.png")),
                              cv2.imread(str(Path(cand) / f"{n}.png"))) for n in plain)
    return len(plain), int(same)


def judge(pairs: list[tuple[Path, Path]], rule: str = "fade", flow: str = "dis") -> dict:
    """One of ``RULES`` (``rule``) on (baseline, candidate) rendered paths of the same builds,
    the warping error by ``flow`` (one of ``FLOWS``; the exposure rule reads Farneback's
    too)."""
    rows = {}
    for base, cand in pairs:
        b, c = path_flicker(base, flow), path_flicker(cand, flow)
        plain, same = same_unfaded(base, cand)
        rows[str(cand)] = {
            "baseline": str(base), "largest": [b["max"], c["max"]], "mean": [b["mean"], c["mean"]],
            "spread": [b["spread"], c["spread"]], "sharpness": [b["sharpness"], c["sharpness"]],
            "brightness": [b["brightness"], c["brightness"]],
            "renders_per_frame": [renders_per_frame(base), renders_per_frame(cand)],
            "unfaded_frames": plain, "unfaded_identical": same}
        if rule == "exposure":  # the mean error by the second flow, the detail at one exposure
            rows[str(cand)]["mean_farneback"] = [path_flicker(x, "farneback")["mean"]
                                                 for x in (base, cand)]
            rows[str(cand)]["matched_sharpness"] = list(matched_sharpness(base, cand))
    keys = ("largest", "mean", "sharpness", "brightness")
    keys += ("mean_farneback", "matched_sharpness") if rule == "exposure" else ()
    rel = {k: float(np.mean([r[k][1] / r[k][0] - 1 for r in rows.values()])) for k in keys}
    down = sum(r["largest"][1] < r["largest"][0] for r in rows.values())
    per_frame = float(np.mean([r["renders_per_frame"][1] for r in rows.values()]))
    before = float(np.mean([r["renders_per_frame"][0] for r in rows.values()]))
    if rule == "exposure":
        checks = {"a": max(rel["mean"], rel["mean_farneback"]) <= EXPOSURE_RULE["mean"],
                  "b": rel["largest"] <= EXPOSURE_RULE["largest"],
                  "c": rel["brightness"] >= EXPOSURE_RULE["brightness"]}
    elif rule == "cut":
        fell = sum(r["mean"][1] < r["mean"][0] for r in rows.values())
        checks = {"a": rel["mean"] <= CUT_RULE["mean"] and fell >= CUT_RULE["mean_paths"],
                  "b": rel["largest"] <= CUT_RULE["largest"],
                  "c": rel["sharpness"] >= CUT_RULE["sharpness"],
                  "d": per_frame <= CUT_RULE["renders_ratio"] * before}
    elif rule == "hold":
        checks = {"a": rel["mean"] <= HOLD_RULE["mean"],
                  "b": rel["largest"] <= HOLD_RULE["largest"],
                  "c": rel["sharpness"] >= HOLD_RULE["sharpness"], "d": per_frame <= before}
    else:
        checks = {"a": rel["largest"] <= RULE["largest"] and down >= RULE["largest_builds"],
                  "b": rel["mean"] <= RULE["mean"], "c": rel["sharpness"] >= RULE["sharpness"],
                  "d": per_frame <= RULE["renders"]}
    return {"builds": rows, "rule_name": rule, "flow": flow,
            "relative": {k: round(v, 4) for k, v in rel.items()},
            "largest_down_on": down, "renders_per_frame": round(per_frame, 4),
            "baseline_renders_per_frame": round(before, 4),
            "checks": checks, "passes": all(checks.values()),
            "identical": all(r["unfaded_identical"] == r["unfaded_frames"]
                             for r in rows.values())}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("paths", nargs="+", type=Path, help="rendered path folders (PNG frames)")
    ap.add_argument("--judge", action="store_true",
                    help="the paths are pairs BASELINE CANDIDATE: score RULE on them")
    ap.add_argument("--rule", choices=tuple(RULES), default="fade",
                    help="with --judge: RULE (fade), HOLD_RULE (hold), EXPOSURE_RULE "
                         "(exposure) or CUT_RULE (cut)")
    ap.add_argument("--flow", choices=FLOWS, default="dis",
                    help="the optical flow that warps each frame onto the one before")
    ap.add_argument("--out", type=Path, help="write the results as JSON here")
    a = ap.parse_args(argv)
    if a.judge and len(a.paths) % 2:
        print("error: --judge takes pairs of folders: BASELINE CANDIDATE ...", file=sys.stderr)
        return 2
    try:
        if a.judge:
            from pipeline.provenance import write_result

            res = judge(list(zip(a.paths[::2], a.paths[1::2], strict=True)), a.rule, a.flow)
            print(json.dumps({k: v for k, v in res.items() if k != "builds"}))
            write_result(a.out, {"rule": RULES[a.rule], **res})
            return 0
        res = {str(p): path_flicker(p, a.flow) for p in a.paths}
    except (SystemExit, OSError, KeyError, ValueError) as e:
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
