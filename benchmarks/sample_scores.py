"""Score the README's main job: the de-flared sample photos against the sample's ground truth.

    deflare-scene samples/cyprus                       # writes samples/cyprus.deflare
    python benchmarks/sample_scores.py [samples/cyprus.deflare] [--truth samples/cyprus_truth]

For every photo of the sample: PSNR of WS/deflared/<stem>.png and of the flared photo
itself against the clean ground truth, over the whole image and inside the true flare mask
(`masks_gt`), at the de-flared image's size. Prints a per-view table and the means.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import cv2
import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))


def score(ws: Path, truth: Path) -> dict:
    from pipeline import metrics
    from pipeline.images import read_image
    from pipeline.workspace import Workspace
    from pipeline.ws_files import read_mask_file

    photos = {p.stem: p for p in (truth / "photos").iterdir() if p.is_file()}
    per = {}
    for out in sorted(Workspace(ws).deflared.glob("*.png")):
        s = out.stem
        pred = read_image(out)
        size = (pred.shape[1], pred.shape[0])
        gt = read_image(truth / "clean" / f"{s}.png", size=size)
        flared = read_image(photos[s], size=size)
        m = read_mask_file(truth / "masks_gt" / f"{s}.png", size=size)
        per[s] = {"psnr": metrics.psnr(pred, gt), "psnr_input": metrics.psnr(flared, gt),
                  "psnr_flare": metrics.masked_psnr(pred, gt, m) if m.any() else None,
                  "psnr_flare_input": metrics.masked_psnr(flared, gt, m) if m.any() else None}
    if not per:
        raise SystemExit(f"error: {ws}/deflared has no photos: run `deflare-scene "
                         "samples/cyprus` first")
    keys = ("psnr", "psnr_input", "psnr_flare", "psnr_flare_input")
    mean = {k: float(np.mean([v[k] for v in per.values() if v[k] is not None])) for k in keys}
    return {"workspace": str(ws), "views": per, "mean": mean}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("workspace", type=Path, nargs="?", default=REPO / "samples" /
                    "cyprus.deflare")
    ap.add_argument("--truth", type=Path, default=REPO / "samples" / "cyprus_truth")
    ap.add_argument("--out", type=Path, default=None, help="Also write the scores (JSON).")
    a = ap.parse_args()
    from pipeline.errors import UserError

    try:
        res = score(a.workspace, a.truth)
    except UserError as e:
        raise SystemExit(f"error: {e}") from None
    print("| view | whole: de-flared / flared | flare region: de-flared / flared |")
    print("|---|---|---|")
    rows = [*res["views"].items(), ("**mean**", res["mean"])]
    for s, v in rows:
        fl = ("—" if v["psnr_flare"] is None
              else f"{v['psnr_flare']:.2f} / {v['psnr_flare_input']:.2f}")
        print(f"| {s} | {v['psnr']:.2f} / {v['psnr_input']:.2f} | {fl} |")
    if a.out:
        res.update(run_facts(a.workspace))
        a.out.parent.mkdir(parents=True, exist_ok=True)
        a.out.write_text(json.dumps(res, indent=2) + "\n")


def run_facts(ws: Path) -> dict:
    """What made the workspace: stage seconds and parameters (manifest), the fine-tuned
    checkpoint's provenance, the video's size and frame count, code and machine."""
    from gnfr.checkpoint import read_metadata
    from pipeline.provenance import code_version, machine
    from pipeline.workspace import Workspace

    w = Workspace(ws)
    stages = w.stage_summary()
    video = w.video if w.video.exists() else None
    facts = {}
    if video is not None and not video.stem.endswith("_compare"):
        cap = cv2.VideoCapture(str(video))
        facts = {"file": video.name, "frames": int(cap.get(cv2.CAP_PROP_FRAME_COUNT)),
                 "width": int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)),
                 "height": int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))}
    _, meta = read_metadata(w.model_file)
    return {"workspace": str(ws), "stages": stages, "video": facts,
            "model": {k: meta.get(k) for k in ("step", "preset", "provenance")},
            "code": code_version(), "machine": machine()}


if __name__ == "__main__":
    main()
