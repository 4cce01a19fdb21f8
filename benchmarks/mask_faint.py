"""How much of what the masks miss is faint flare: scores against stricter true flare.

Flare IoU and recall against the true flare at stricter thresholds, the fainter flare between
them left out of the score.

    python benchmarks/mask_faint.py SYNTH [SYNTH ...] --weights W [--scale 2 --scale 4] \
        [--out docs/results/mask_faint.json]

The true masks of `deflare-scene synth` (``masks_gt``) mark every pixel where the added flare's
linear luminance is above the mask rule's thresholds (0.012, and 10 % of the smoothed
background's luminance: ``pipeline.flare.common.MASK_THRESHOLD``, ``MASK_RELATIVE``). A spike a
few grey levels above a sunlit facade counts as much as the light's glow. For each ``--scale``
K this reads the true flare at K times both thresholds (``truth_masks_at``, the flare read back
as flared minus clean in linear light) and scores the mask stage's masks (`mask --rays`, the
file's own cut) against it with the flare that is true at 1x but not at K left out: neither
a hit nor a miss nor a false mark (``faint_scores``). K = 1 is the usual flare IoU. Per scene
and pooled per kind of flare over scenes named ``<scene>_<kind>`` (the one-kind builds of
``benchmarks/mask_kind_scenes.py``): the mean over its scenes, as ``judge`` pools them, and
its pixels pooled. A diagnosis of what the masks miss; it changes no
threshold and decides nothing.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def faint_scores(marks: np.ndarray, truth: np.ndarray, strict: np.ndarray) -> dict:
    """Pixel counts of one view: ``marks`` against ``strict`` (the true flare at a stricter
    threshold, a subset of ``truth``), the pixels of ``truth`` not in ``strict`` left out.
    ``inter``, ``union`` (the IoU's), ``strict`` (its pixels) and ``hit`` (of them marked)."""
    keep = ~(truth & ~strict)
    return {"inter": int((marks & strict).sum()), "union": int(((marks | strict) & keep).sum()),
            "strict": int(strict.sum()), "hit": int((marks & strict).sum())}


def pooled(counts: list[dict]) -> dict:
    """Flare IoU and recall of summed :func:`faint_scores` counts (None where undefined)."""
    s = {k: sum(c[k] for c in counts) for k in ("inter", "union", "strict", "hit")}
    return {"flare_iou": s["inter"] / s["union"] if s["union"] else None,
            "recall": s["hit"] / s["strict"] if s["strict"] else None,
            "strict_pixels": s["strict"]}


def kind_scores(scenes: list[list[dict]]) -> dict:
    """One kind's scores over its scenes (each a list of per-view counts): the mean over the
    scenes of each scene's flare IoU (as ``mask_kind_scenes.py`` pools, a scene whose strict
    flare and marks are both empty left out) and the pixels of every scene pooled."""
    per = [pooled(c)["flare_iou"] for c in scenes]
    per = [v for v in per if v is not None]
    return {"mean_scene_iou": sum(per) / len(per) if per else 0.0, "scenes": len(per),
            **pooled([c for scene in scenes for c in scene])}


def scene_counts(model, cut: float, synth: Path, scales: list[float],
                 work_size: int = 512) -> dict[float, list[dict]]:
    """{K: [per-view counts]} of the mask stage's masks (rays on) on the training views of one
    synth folder (those without flare too: their marks are false marks, as in
    ``mask_dev_scenes.py``, so K = 1 is its flare IoU)."""
    from pipeline.images import read_image
    from pipeline.mask import flare_marks
    from workflows.research.eval.scene import load_synth, photo_path, truth_mask, truth_masks_at

    scene = load_synth(synth)
    out: dict[float, list[dict]] = {k: [] for k in scales}
    for stem in scene.train:
        truth = truth_mask(scene, stem)
        marks = flare_marks(model, read_image(photo_path(scene.root, stem), bgr=True), cut,
                            work_size, True)
        stricter = truth_masks_at(scene, stem, [k for k in scales if k != 1])
        for k in scales:
            strict = truth if k == 1 else truth & stricter[k]
            out[k].append(faint_scores(marks, truth, strict))
    return out


def kind_of(name: str) -> str | None:
    """The kind of flare of a one-kind scene ``<scene>_<kind>``, else None."""
    from pipeline.flare import KINDS

    tail = name.rsplit("_", 1)[-1]
    return tail if tail in KINDS and "_" in name else None


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", type=Path, nargs="+")
    ap.add_argument("--weights", type=Path, required=True)
    ap.add_argument("--scale", type=float, action="append", default=None,
                    help="a stricter threshold, times the mask rule's (repeat; default 2 and 4)")
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    scales = sorted({1.0, *(a.scale or [2.0, 4.0])})
    if scales[0] < 1:
        ap.error("--scale: each at least 1 (the mask rule's own thresholds)")
    from pipeline.errors import UserError
    from pipeline.mask import MaskConfig, load_fmg_weights, resolve_threshold
    from pipeline.provenance import sha256, write_result

    try:
        model = load_fmg_weights(a.weights)
        cut = resolve_threshold(MaskConfig(), a.weights)
        rows, per_kind = [], {}
        for scene in a.scenes:
            counts = scene_counts(model, cut, scene, scales)
            row = {"scene": f"{scene.parent.name}/{scene.name}",
                   **{f"x{k:g}": pooled(counts[k]) for k in scales}}
            rows.append(row)
            kind = kind_of(scene.name)
            if kind is not None and counts[1.0]:
                for k in scales:
                    per_kind.setdefault(kind, {}).setdefault(k, []).append(counts[k])
            print(scene.name + ": " + ", ".join(
                f"x{k:g} IoU {row[f'x{k:g}']['flare_iou'] or 0:.3f} recall "
                f"{row[f'x{k:g}']['recall'] or 0:.3f}" for k in scales), flush=True)
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    kinds = {kind: {f"x{k:g}": kind_scores(v[k]) for k in scales}
             for kind, v in per_kind.items()}
    for kind, r in kinds.items():
        print(f"{kind:>9}: " + ", ".join(f"x{k:g} IoU {r[f'x{k:g}']['mean_scene_iou']:.3f}"
                                         for k in scales))
    write_result(a.out, {"weights": str(a.weights), "sha256": sha256(a.weights), "cut": cut,
                         "scales": scales, "rows": rows, "kinds": kinds})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
