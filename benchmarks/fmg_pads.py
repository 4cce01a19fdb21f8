"""Whether the FMG's marks hold when its input is padded: true flare against clean photos.

    python benchmarks/fmg_pads.py --synth SYNTH [SYNTH ...] --clean WS [WS ...] \
        [--weights W] [--out RESULT.json]

The network alone (its file's cut, no rays, no ghost lines) runs on each photo as it is
(``plain``) and on the photo padded at every edge by ``gnfr.fmg.PAD_SHARE`` (3 %) of the
long side at its working size in each of ``gnfr.fmg.PAD_MODES`` (``reflect``: mirrored,
``replicate``: the edge repeated, ``constant``: black), each output cropped back. For each
pass alone and for the four maps combined before the cut (``mean``, ``median``, ``min``: a
pixel stays flare only if every pass marks it, `mask --pads reflect,replicate,constant`),
and for ``regions`` (the plain pass's regions kept whole where ``min`` keeps a pixel of
them), it reports:

- on each SYNTH folder of `deflare-scene synth` (its ``photos/`` and ``masks_gt/``): flare
  IoU pooled over the views;
- on each posed workspace WS of clean photos (its ``images/``): the share of the pixels
  marked, every mark a false one.

This is the exploration behind `mask --pads` (docs/history/fmg.md, "Seventy-second
session"); the rule that judged it runs the mask stage itself
(``benchmarks/mask_views_scenes.py --pads``, ``benchmarks/mask_dev_scenes.py --pads``).
Use development scenes to choose.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def pass_probs(model, image_bgr: np.ndarray, work_size: int) -> dict[str, np.ndarray]:
    """{"plain" and each of ``PAD_MODES``: [H, W] probabilities} of one BGR uint8 image: the
    network at ``work_size`` (resampled as ``gnfr.fmg.predict_probs`` does) on the image as
    it is and padded in that mode by ``PAD_SHARE`` of the long side, cropped back."""
    import torch
    import torch.nn.functional as F

    from gnfr.fmg import PAD_MODES, padded_pass, work_shape

    x = torch.from_numpy(np.ascontiguousarray(image_bgr[..., ::-1]).astype(np.float32)
                         / 255.0).permute(2, 0, 1)[None]
    h, w = x.shape[-2:]
    xs = F.interpolate(x, size=work_shape(h, w, work_size), mode="bilinear",
                       align_corners=False, antialias=True)
    model.eval()
    with torch.no_grad():
        passes = {"plain": torch.sigmoid(model(xs)),
                  **{mode: padded_pass(model, xs, mode) for mode in PAD_MODES}}
    return {k: F.interpolate(p, size=(h, w), mode="bilinear", align_corners=False)[0, 0]
            .numpy() for k, p in passes.items()}


def combined_marks(probs: dict[str, np.ndarray], cut: float) -> dict[str, np.ndarray]:
    """The marks [H, W] bool of each pass alone and of the four combined (mean, median,
    min: `mask --pads reflect,replicate,constant`)."""
    stack = np.stack(list(probs.values()))
    marks = {**{k: v > cut for k, v in probs.items()}, "mean": stack.mean(0) > cut,
             "median": np.median(stack, 0) > cut, "min": stack.min(0) > cut}
    from pipeline.mask import regions_touching

    marks["regions"] = regions_touching(marks["plain"], marks["min"])
    return marks


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--synth", type=Path, nargs="*", default=[])
    ap.add_argument("--clean", type=Path, nargs="*", default=[])
    ap.add_argument("--weights", type=Path, default=None)
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    if not a.synth and not a.clean:
        ap.error("give --synth folders, --clean workspaces, or both")
    for d, sub in [(s, "masks_gt") for s in a.synth] + [(w, "images") for w in a.clean]:
        if not (d / sub).is_dir():
            print(f"error: {d}: no {sub}/ folder", file=sys.stderr)
            return 2
    from workflows.threads import apply_thread_policy

    apply_thread_policy()
    import cv2

    from pipeline.images import list_photos, read_image
    from pipeline.mask import DEFAULT_WEIGHTS, MaskConfig, load_fmg_weights, resolve_threshold
    from pipeline.provenance import sha256, write_result

    weights = (a.weights or DEFAULT_WEIGHTS).resolve()
    model = load_fmg_weights(weights)
    cut = resolve_threshold(MaskConfig(), weights)
    work_size = MaskConfig().work_size
    synth, clean = {}, {}
    for folder in a.synth:
        inter, union = {}, {}
        for photo in list_photos(folder / "photos"):
            gt_path = folder / "masks_gt" / f"{photo.stem}.png"
            if not gt_path.exists():
                continue
            gt = cv2.imread(str(gt_path), cv2.IMREAD_GRAYSCALE) > 127
            marks = combined_marks(pass_probs(model, read_image(photo, bgr=True), work_size),
                                   cut)
            for k, m in marks.items():
                inter[k] = inter.get(k, 0) + int((m & gt).sum())
                union[k] = union.get(k, 0) + int((m | gt).sum())
        synth[folder.name] = {k: inter[k] / max(union[k], 1) for k in inter}
        print(f"{folder.name}: flare IoU " + ", ".join(
            f"{k} {v:.3f}" for k, v in synth[folder.name].items()), flush=True)
    for ws in a.clean:
        marked, pixels = {}, 0
        for f in sorted((ws / "images").glob("*.png")):
            marks = combined_marks(pass_probs(model, read_image(f, bgr=True), work_size), cut)
            for k, m in marks.items():
                marked[k] = marked.get(k, 0) + int(m.sum())
            pixels += next(iter(marks.values())).size
        clean[ws.name] = {k: v / max(pixels, 1) for k, v in marked.items()}
        print(f"{ws.name}: marked " + ", ".join(
            f"{k} {100 * v:.3f} %" for k, v in clean[ws.name].items()), flush=True)
    write_result(a.out, {"weights": str(weights), "sha256": sha256(weights), "cut": cut,
                         "work_size": work_size, "synth_flare_iou": synth,
                         "clean_marked": clean})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
