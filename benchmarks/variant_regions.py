"""Where two eval variants' de-flared photos differ inside the true flare, and who is closer there.

    python benchmarks/variant_regions.py EVAL_WS SYNTH [--a gnfr] [--b gnt] --out JSON

`deflare-scene eval` renders every neural variant's de-flared photos through the same
mask-guided fill: inside the flare the pixels the neighbouring photos agree on are the
photos' for every variant, the rest the variant's network's. This splits each photo's true
flare region (``SYNTH/masks_gt``) into the pixels where variants ``--a`` and ``--b``
(``EVAL_WS/variants/<name>/deflared``) are identical (the photos') and where they differ (the
networks'), and scores both variants against ``SYNTH/clean`` on the differing pixels (PSNR of
the pooled squared error): how much of the flare region the network draws and what its
flare handling is worth there (docs/eval.md, "The README's results, row by row").
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def split(eval_ws: Path, synth: Path, a: str, b: str) -> dict:
    """{identical_share (mean over photos), psnr_a, psnr_b (on the differing pixels),
    photos} for one evaluation workspace."""
    from pipeline.errors import UserError
    from pipeline.images import read_image
    from pipeline.ws_files import read_mask_file

    dirs = {v: eval_ws / "variants" / v / "deflared" for v in (a, b)}
    for v, d in dirs.items():
        if not d.is_dir():
            raise UserError(f"{d}: no de-flared photos of variant {v}; run `deflare-scene eval "
                            f"SCENE --variants {a},{b}` first")
    shares, err_a, err_b = [], [], []
    fix = f"run `deflare-scene eval SCENE --variants {a},{b}` on the scene {synth} was built as"
    for png in sorted(dirs[a].glob("*.png")):
        flare = read_mask_file(synth / "masks_gt" / png.name, fix=fix)
        if not flare.any():
            continue
        ia, ib, gt = (read_image(f, fix=fix).astype(np.float64) / 255
                      for f in (png, dirs[b] / png.name, synth / "clean" / png.name))
        same = np.all(ia == ib, axis=2) & flare
        differ = flare & ~same
        shares.append(float(same.sum() / flare.sum()))
        err_a.append(((ia - gt) ** 2).mean(axis=2)[differ])
        err_b.append(((ib - gt) ** 2).mean(axis=2)[differ])
    if not shares:
        raise UserError(f"{dirs[a]}: no photo with true flare to score")

    def psnr(errs: list[np.ndarray]) -> float:
        return float(-10 * np.log10(max(float(np.concatenate(errs).mean()), 1e-12)))

    return {"photos": len(shares), "identical_share": float(np.mean(shares)),
            f"psnr_{a}": psnr(err_a), f"psnr_{b}": psnr(err_b)}


def main(argv: list[str] | None = None) -> int:
    from pipeline.errors import UserError

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("eval_ws", type=Path)
    ap.add_argument("synth", type=Path)
    ap.add_argument("--a", default="gnfr")
    ap.add_argument("--b", default="gnt")
    ap.add_argument("--out", type=Path)
    args = ap.parse_args(argv)
    try:
        res = split(args.eval_ws, args.synth, args.a, args.b)
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(f"{res['photos']} photos: {100 * res['identical_share']:.1f} % of the flare region "
          f"identical; elsewhere {args.a} {res[f'psnr_{args.a}']:.2f} dB, {args.b} "
          f"{res[f'psnr_{args.b}']:.2f} dB")
    if args.out:
        from pipeline.provenance import write_result
        write_result(args.out, {"eval_ws": str(args.eval_ws), "synth": str(args.synth),
                                "a": args.a, "b": args.b, **res})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
