"""Overview image of the FMG's hard negatives (docs/hard_negatives.jpg).

    python benchmarks/negatives_overview.py [--data ../shared/data] [--out docs/hard_negatives.jpg]
        [--seed 0] [--per-kind 4]

One row per kind of ``pipeline.fmg_data.HARD_NEGATIVES`` (each painted alone, as `fmg train
--negatives` paints it, on a random crop of a training background, night on a third of
them), labelled with its name and whether `fmg train` draws it by default. Nothing in these
composites is flare: they teach the network what to leave unmarked. A JPEG under 200 KB,
deterministic for a seed.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks.flare_kinds_overview import MAX_BYTES, write_jpeg  # noqa: E402, F401

TILE = 192


def overview(data: Path, seed: int = 0, per_kind: int = 4) -> np.ndarray:
    """BGR uint8 grid: a row per hard negative, ``per_kind`` composites each."""
    from pipeline.fmg_data import (
        DEFAULT_NEGATIVES,
        HARD_NEGATIVES,
        CompositeConfig,
        add_hard_negatives,
        darken_night,
        load_backgrounds,
        random_crop,
        split_backgrounds,
    )
    from pipeline.images import put_label

    bgs = load_backgrounds(split_backgrounds(data).train, 384)
    comp = CompositeConfig(size=TILE, night_gain=(0.03, 0.2))
    rows = []
    for i, kind in enumerate(HARD_NEGATIVES):
        rng = np.random.default_rng(seed * 1000 + i)
        tiles = []
        for j in range(per_kind):
            img = random_crop(bgs[int(rng.integers(len(bgs)))], TILE, comp.crop_scale, rng)
            if j % 3 == 2:
                img = darken_night(img, comp, rng)
            tile = (np.clip(add_hard_negatives(img, rng, (kind,)), 0, 1)[..., ::-1] * 255)
            tiles.append(np.ascontiguousarray(tile.astype(np.uint8)))
        row = np.hstack(tiles)
        label = kind + ("" if kind in DEFAULT_NEGATIVES else " (option)")
        put_label(row, label, scale=0.6)
        rows.append(row)
    return np.vstack(rows)


def main(argv: list[str] | None = None) -> int:
    from pipeline.errors import UserError

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=ROOT.parent / "shared" / "data")
    ap.add_argument("--out", type=Path, default=ROOT / "docs" / "hard_negatives.jpg")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--per-kind", type=int, default=4)
    a = ap.parse_args(argv)
    try:
        img = overview(a.data, a.seed, a.per_kind)
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    a.out.parent.mkdir(parents=True, exist_ok=True)
    print(f"wrote {a.out} ({write_jpeg(a.out, img) // 1000} KB)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
