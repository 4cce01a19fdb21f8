"""How bright each folder's photos are: the median and 75th percentile of a photo's luminance.

    python benchmarks/scene_luminance.py FOLDER [FOLDER ...] [--out JSON]

Per folder, every photo OpenCV reads (``pipeline.images.list_photos``): the photo's
luminance (Rec. 709 weights on its sRGB values in 0..1, as stored) reduced to its median
and 75th percentile, then the smallest and largest of those over the folder. Made to ask
whether one brightness cut could tell night captures from daylight ones (docs/history/fmg.md,
"Ninety-seventh session").
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

REC709 = (0.2126, 0.7152, 0.0722)


def luminance_stats(rgb: np.ndarray) -> tuple[float, float]:
    """(median, 75th percentile) of the luminance of an [h, w, 3] RGB image in 0..1."""
    y = rgb @ np.asarray(REC709, np.float32)
    return float(np.median(y)), float(np.percentile(y, 75))


def folder_stats(folder: Path) -> dict:
    """Each photo's stats and the folder's range of them."""
    from pipeline.errors import UserError
    from pipeline.images import list_photos, read_image_float

    if not folder.is_dir():
        raise UserError(f"{folder} is not a folder: pass folders of photos")
    photos = {p.name: luminance_stats(read_image_float(p)) for p in list_photos(folder)}
    if not photos:
        raise UserError(f"{folder} holds no photos (JPEG/PNG/TIFF...): pass folders of photos")
    medians = [m for m, _ in photos.values()]
    return {"photos": {k: {"median": m, "p75": q} for k, (m, q) in photos.items()},
            "median_min": min(medians), "median_max": max(medians)}


def main(argv: list[str] | None = None) -> int:
    from pipeline.errors import UserError

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folders", type=Path, nargs="+")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    result = {}
    try:
        for folder in args.folders:
            stats = folder_stats(folder)
            result[str(folder)] = stats
            print(f"{folder}: {len(stats['photos'])} photos, median luminance "
                  f"{stats['median_min']:.3f} to {stats['median_max']:.3f}")
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    if args.out:
        from pipeline.provenance import write_result

        write_result(args.out, {"folders": result})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
