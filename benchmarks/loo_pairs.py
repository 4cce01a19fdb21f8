"""Left-out views of a render setting against a baseline, build by build.

    python benchmarks/loo_pairs.py BASE.json CAND.json [BASE2.json CAND2.json ...] --out FILE

Each file is a ``benchmarks/novel_loo.py`` record of one fine-tuned workspace (the same
views in both of a pair, rendered with and without the setting). Writes each pair's PSNR and
SSIM, their differences, and the differences' mean over the pairs (each pair weighs the
same, whatever its number of views). Bad input: one line on stderr, exit 2.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def pairs_table(pairs: list[tuple[Path, Path]]) -> dict:
    """{"pairs": {candidate file: {...}}, "mean": {"psnr": dB, "ssim": ...}}."""
    rows = {}
    for base, cand in pairs:
        b, c = (json.loads(Path(x).read_text()) for x in (base, cand))
        if b["views"] != c["views"]:
            raise ValueError(f"{cand}: not the views of {base} (render the same workspace)")
        rows[str(cand)] = {"baseline": str(base), "views": len(b["views"]),
                           "psnr": [b["psnr"], c["psnr"]], "ssim": [b["ssim"], c["ssim"]],
                           "d_psnr": round(c["psnr"] - b["psnr"], 4),
                           "d_ssim": round(c["ssim"] - b["ssim"], 5)}
    n = len(rows)
    return {"pairs": rows,
            "mean": {"psnr": round(sum(r["d_psnr"] for r in rows.values()) / n, 4),
                     "ssim": round(sum(r["d_ssim"] for r in rows.values()) / n, 5)}}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("files", nargs="+", type=Path, help="BASE CAND pairs of novel_loo records")
    ap.add_argument("--out", type=Path, help="write the table as JSON here")
    a = ap.parse_args(argv)
    if len(a.files) % 2:
        print("error: give pairs of files: BASE CAND ...", file=sys.stderr)
        return 2
    try:
        res = pairs_table(list(zip(a.files[::2], a.files[1::2], strict=True)))
    except (OSError, KeyError, ValueError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    for cand, r in res["pairs"].items():
        print(f"{cand}: PSNR {r['psnr'][0]:.3f} -> {r['psnr'][1]:.3f} ({r['d_psnr']:+.3f} dB), "
              f"SSIM {r['ssim'][0]:.4f} -> {r['ssim'][1]:.4f} ({r['d_ssim']:+.4f})")
    print(f"mean: {res['mean']['psnr']:+.3f} dB, SSIM {res['mean']['ssim']:+.4f}")
    from pipeline.provenance import write_result

    write_result(a.out, res)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
