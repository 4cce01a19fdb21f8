"""A figure of one held-out camera as several A/B arms rendered it, beside the truth.

The arms are ``benchmarks/fmg_photo_ab.py``'s; each tile is labelled with its arm and PSNR.

    python benchmarks/arm_frames.py SYNTH STEM --work DIR --seed S --arms s50_near,s50_nkb50 \
        [--labels "no lean,key blend 0.5"] [--height 240] --out FIG.jpg

Reads DIR/<scene>_<arm>_s<S>.ws/renders/heldout_cameras/STEM.png (``fmg_photo_ab.py run`` or
``rerender``) and SYNTH/clean/STEM.png; writes one row: truth, then the arms in order.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def tile(img: np.ndarray, label: str, height: int) -> np.ndarray:
    """``img`` (BGR uint8) scaled to ``height``, captioned with ``label`` as the eval's
    report captions its tiles (``workflows.research.eval.report.caption_tile``)."""
    from workflows.research.eval.report import caption_tile

    w = max(1, round(img.shape[1] * height / img.shape[0]))
    return caption_tile(img, (w, height), label)


def figure(synth: Path, stem: str, work: Path, seed: int, arms: list[str],
           labels: list[str], height: int) -> np.ndarray:
    from pipeline import metrics
    from pipeline.errors import UserError
    from pipeline.images import read_image

    scene = synth.name.removesuffix("_synth")
    truth_path = synth / "clean" / f"{stem}.png"
    if not truth_path.is_file():
        raise UserError(f"{truth_path}: no clean photo of {stem}; give a held-out view of "
                        f"{synth}")
    tiles = []
    for arm, label in zip(arms, labels, strict=True):
        p = work / f"{scene}_{arm}_s{seed}.ws" / "renders" / "heldout_cameras" / f"{stem}.png"
        if not p.is_file():
            raise UserError(f"{p}: no such render; run the arm first "
                            "(python benchmarks/fmg_photo_ab.py run|rerender ...)")
        img = read_image(p, bgr=True, fix="rerun the arm")
        if not tiles:
            truth = read_image(truth_path, bgr=True, size=(img.shape[1], img.shape[0]),
                               fix=f"rerun `deflare-scene synth ... --out {synth}`")
            tiles.append(tile(truth, f"truth {stem}", height))
        tiles.append(tile(img, f"{label}: {metrics.psnr(img, truth):.2f} dB", height))
    return np.hstack(tiles)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("synth", type=Path)
    ap.add_argument("stem")
    ap.add_argument("--work", type=Path, required=True)
    ap.add_argument("--seed", type=int, required=True)
    ap.add_argument("--arms", required=True, help="arms, comma-separated")
    ap.add_argument("--labels", default=None, help="their labels, comma-separated")
    ap.add_argument("--height", type=int, default=240)
    ap.add_argument("--out", type=Path, required=True)
    a = ap.parse_args(argv)
    import cv2

    from pipeline.errors import UserError

    arms = a.arms.split(",")
    labels = arms if a.labels is None else a.labels.split(",")
    try:
        if len(labels) != len(arms):
            raise UserError(f"--labels gives {len(labels)} labels for {len(arms)} arms")
        fig = figure(a.synth, a.stem, a.work, a.seed, arms, labels, a.height)
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    a.out.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(a.out), fig, [cv2.IMWRITE_JPEG_QUALITY, 88])
    print(a.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
