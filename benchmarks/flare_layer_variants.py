"""The flare layer's variants on evaluated scenes: which way of keeping the photo's detail.

Renders the de-flared inputs of a trained `eval` variant once with the fill pasted
(``--flare-layer 0``), then recomputes the flare layer (pipeline/render/flare_layer.py)
from that fill in several ways and scores each inside the true flare region, over the
whole photo and by SSIM. The variants use the true mask as the blend region (the render
stage uses its dilated, feathered mask), so their numbers differ a little from the render
stage's own; they compare the variants with one another.

    python benchmarks/flare_layer_variants.py SCENE_SYNTH [SCENE_SYNTH ...] --out JSON

Variants: the layer's scale (fraction of the long side); ``norm``: the blurred difference
divided by the blurred mask (the whole difference removed even in small regions);
``floor``: the result kept at least this fraction of the fill; ``cap``: the result kept
at most the fill plus this (linear) tolerance plus ``rel`` x the fill (sharp flare above
the fill removed); ``noclip``: clipped pixels left out of the layer; ``resid``: after the
layer, the part of what is left above the fill (mean over channels) that exceeds ``resid`` x
its median magnitude over the mask is removed too (for thin sharp flare; seventh session);
``shrink``: the layer lowered by this (linear) amount, so differences smaller than it are
left in the photo (faint flare kept rather than the fill's error; eighth session);
``bias``: the fill first corrected by its local error on the ring (``local_bias`` below; the
ring is the render stage's: the mask dilated by ``RenderConfig.dilate``, less the mask; ninth
session; the render option it was tried as, ``--layer-bias``, was removed in the eleventh
after it failed its rule, docs/history/fill.md, "The flare layer: measured (sixth
session)").
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

VARIANTS = {
    "scale_0.03": {"smooth": 0.03}, "scale_0.06": {"smooth": 0.06},
    "scale_0.12 (default)": {"smooth": 0.12}, "scale_0.25": {"smooth": 0.25},
    "scale_0.5": {"smooth": 0.5},
    "norm_0.03": {"smooth": 0.03, "norm": True}, "norm_0.06": {"smooth": 0.06, "norm": True},
    "norm_0.12": {"smooth": 0.12, "norm": True}, "norm_0.25": {"smooth": 0.25, "norm": True},
    "floor_0.5": {"floor": 0.5}, "floor_0.75": {"floor": 0.75},
    "cap_0.01": {"cap": 0.01}, "cap_0.03": {"cap": 0.03}, "cap_0.1": {"cap": 0.1},
    "cap_0+0.5f": {"cap": 0.0, "rel": 0.5}, "cap_0+1.0f": {"cap": 0.0, "rel": 1.0},
    "noclip": {"noclip": True},
    "resid_1": {"resid": 1.0}, "resid_2": {"resid": 2.0}, "resid_3": {"resid": 3.0},
    "shrink_0.003": {"shrink": 0.003}, "shrink_0.01": {"shrink": 0.01},
    "shrink_0.03": {"shrink": 0.03},
    "bias_0.03": {"bias": 0.03}, "bias_0.06": {"bias": 0.06}, "bias_0.12": {"bias": 0.12},
    "bias_0.25": {"bias": 0.25},
    "bias_0.06+norm_0.12": {"bias": 0.06, "norm": True},
    "bias_0.12+norm_0.12": {"bias": 0.12, "norm": True},
    "bias_0.12+norm_0.25": {"bias": 0.12, "norm": True, "smooth": 0.25},
}


BIAS_SUPPORT = 0.01
"""Normalised averages with less ring weight than this (of a full neighbourhood) are faded
towards no correction: far from every ring pixel the fill's error is not known."""


def local_bias(error, ring, smooth: float):
    """[H, W, C] the fill's local error: ``error`` [H, W, C] (photo - fill, linear) averaged
    over the ``ring`` [H, W] bool pixels by a Gaussian of ``smooth`` x the long side
    (normalised convolution), faded to 0 where the ring's weight is under BIAS_SUPPORT."""
    import numpy as np

    from pipeline.render.flare_layer import lowpass

    r = ring.astype(np.float32)[..., None]
    return lowpass(error * r, smooth) / np.maximum(lowpass(r, smooth), BIAS_SUPPORT)


def ring_of(mask):
    """The render stage's colour-match ring of a mask: grown by RenderConfig.dilate x the
    long side (elliptic), less the mask (pipeline.render.inputs.input_blend)."""
    import cv2
    import numpy as np

    from pipeline.render import RenderConfig

    r = max(1, round(RenderConfig.dilate * max(mask.shape)))
    k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
    return (cv2.dilate(mask.astype(np.uint8), k) > 0) & ~mask


def variant(fill, photo, mask, smooth=0.12, norm=False, floor=None, cap=None, rel=0.0,
            noclip=False, resid=None, shrink=None, bias=None):
    """uint8 BGR result of one variant (fill, photo: uint8 BGR; mask: [H, W] bool)."""
    import numpy as np

    from pipeline.colour import linear_to_srgb, srgb_to_linear
    from pipeline.render.flare_layer import clipped_pixels, lowpass

    p, f = srgb_to_linear(photo / 255.0), srgb_to_linear(fill / 255.0)
    clip = clipped_pixels(photo / 255.0)
    m = mask.astype(np.float32)
    if bias is not None:
        f = np.where(mask[..., None], np.maximum(f + local_bias(p - f, ring_of(mask), bias),
                                                 0.0), f)
    d = (p - f) * m[..., None]
    if noclip:
        d = d * (~clip)[..., None]
    layer = lowpass(d, smooth)
    if norm:
        layer = layer / np.maximum(lowpass(m[..., None], smooth), 1e-4)
    if shrink is not None:
        layer = layer - shrink
    c = p - np.maximum(layer, 0.0)
    if floor is not None:
        c = np.maximum(c, floor * f)
    if cap is not None:
        c = np.minimum(c, f + cap + rel * f)
    if resid is not None and mask.any():
        y = (c - f).mean(-1)
        c = c - (np.maximum(y - resid * np.median(np.abs(y[mask])), 0.0) * m)[..., None]
    w = (m * ~clip)[..., None]
    out = f * (1 - w) + np.clip(c, 0.0, 1.0) * w
    return np.clip(linear_to_srgb(out) * 255 + 0.5, 0, 255).astype(np.uint8)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", type=Path, nargs="+")
    ap.add_argument("--variant", default="gnfr")
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--only", default="",
                    help="comma-separated name prefixes of the variants to score (default all)")
    a = ap.parse_args(argv)
    keep = tuple(x for x in a.only.split(",") if x)
    variants = {k: v for k, v in VARIANTS.items() if not keep or k.startswith(keep)}
    from workflows.threads import apply_thread_policy

    apply_thread_policy()  # before torch loads (workflows/threads.py)
    import cv2
    import numpy as np

    from pipeline import metrics, render
    from pipeline.provenance import write_result
    from pipeline.workspace import Workspace
    from workflows.research.eval.scene import flared_views, load_synth, truth_mask
    from workflows.research.eval.scoring import read_bgr

    rec = {"variants": variants, "scenes": {}}
    for root in a.scenes:
        scene = load_synth(root)
        ws = Workspace(Workspace(root / "eval.ws").variants / a.variant)
        render.run(render.RenderConfig(path="inputs", flare_layer=0.0), ws, force=True)
        per: dict[str, list] = {}
        for s in flared_views(scene):
            fill = read_bgr(ws.deflared / f"{s}.png")
            h, w = fill.shape[:2]
            gt = read_bgr(scene.root / "clean" / f"{s}.png", (h, w))
            photo = read_bgr(scene.root / "photos" / f"{s}.png", (h, w))
            tm = truth_mask(scene, s)
            m = cv2.resize(tm.astype(np.uint8), (w, h), interpolation=cv2.INTER_NEAREST) > 0
            outs = {"fill pasted": fill, "flared input": photo}
            outs.update({k: variant(fill, photo, m, **kw) for k, kw in variants.items()})
            for k, v in outs.items():
                per.setdefault(k, []).append((metrics.masked_psnr(v, gt, tm),
                                              metrics.psnr(v, gt), metrics.ssim(v, gt)))
        rows = {k: {"psnr_flare": round(float(np.mean([r[0] for r in v])), 3),
                    "psnr": round(float(np.mean([r[1] for r in v])), 3),
                    "ssim": round(float(np.mean([r[2] for r in v])), 4)}
                for k, v in per.items()}
        rec["scenes"][str(root)] = {"origin": scene.origin, "rows": rows}
        print(root)
        for k, r in rows.items():
            print(f"  {k:22s} {r['psnr_flare']:6.2f} {r['psnr']:6.2f} {r['ssim']:.4f}", flush=True)
    write_result(a.out, rec)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
