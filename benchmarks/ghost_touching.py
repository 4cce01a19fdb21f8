"""Of what the ghost lines' views add to the masks, the share next to the network's own marks.

    python benchmarks/ghost_touching.py WORK SYNTH [SYNTH ...] [--out J]

A diagnosis for `mask --ghost-views` (docs/history/fmg.md, "Thirty-sixth session"): on a
clean 29-photo capture nearly every false pixel the views added lay in a region touching the
network's own marks, where the network's weak pixels are mostly a halo. For each synth folder
scored by `benchmarks/mask_views_scenes.py SYNTH ... --work WORK` (its workspace
WORK/<name>_photos.ws keeps the last setting's masks, the ghost views', with the network's
masks in masks_fmg), this splits the pixels the views added (WS/masks minus WS/masks_fmg) by
whether their 8-connected region touches the network's marks
(``benchmarks/clean_capture.touching_regions``), and counts how many of each are true flare
(SYNTH/masks_gt): would leaving the touching regions out keep the true ghosts?
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def split_added(added: np.ndarray, own: np.ndarray, truth: np.ndarray) -> dict[str, int]:
    """Pixel counts of ``added`` in regions touching ``own`` and apart, each in and out of
    ``truth`` (all [H, W] bool)."""
    from benchmarks.clean_capture import touching_regions

    touch = touching_regions(added, own)
    apart = added & ~touch
    return {"touching": int(touch.sum()), "touching_true": int((touch & truth).sum()),
            "apart": int(apart.sum()), "apart_true": int((apart & truth).sum())}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("work", type=Path)
    ap.add_argument("synth", type=Path, nargs="+")
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    from pipeline.errors import UserError
    from pipeline.provenance import write_result
    from pipeline.ws_files import read_mask_file

    rows, total = {}, {}
    try:
        for synth in a.synth:
            ws = a.work / f"{synth.name.rstrip('/')}_photos.ws"
            if not (ws / "masks_fmg").is_dir():
                raise UserError(f"{ws} has no masks_fmg: run benchmarks/mask_views_scenes.py "
                                f"{synth} --work {a.work} first")
            row = dict.fromkeys(("touching", "touching_true", "apart", "apart_true"), 0)
            for p in sorted((ws / "masks").glob("*.png")):
                final = read_mask_file(p)
                own = read_mask_file(ws / "masks_fmg" / p.name)
                truth = read_mask_file(synth / "masks_gt" / p.name,
                                       size=(final.shape[1], final.shape[0]))
                for k, v in split_added(final & ~own, own, truth).items():
                    row[k] += v
            rows[synth.name] = row
            for k, v in row.items():
                total[k] = total.get(k, 0) + v
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    for name, r in {**rows, "all": total}.items():
        print(f"{name}: added {r['touching'] + r['apart']} px; touching the network's marks "
              f"{r['touching']} ({r['touching_true']} true), apart {r['apart']} "
              f"({r['apart_true']} true)")
    if a.out:
        write_result(a.out, {"work": str(a.work), "scenes": rows, "all": total})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
