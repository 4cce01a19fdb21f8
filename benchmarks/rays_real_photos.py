"""Share of each photo the flare rays alone mark, under several ray settings.

    python benchmarks/rays_real_photos.py PHOTO [PHOTO ...] --out JSON

For photos without true masks (the real night photos of ../shared/data/flare_real): which
settings mark the lamp streaks at all (see docs/history/fmg.md, "Fifth session"). Settings:
1 ray, 3 rays (the mask stage's default), 3 rays or 2 opposite within 8 degrees. At the mask
stage's working size (512).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

SETTINGS = {"min_rays_1": {"min_rays": 1}, "min_rays_3": {"min_rays": 3},
            "min_rays_3_opposite_8": {"min_rays": 3, "opposite": 8.0}}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("photos", type=Path, nargs="+")
    ap.add_argument("--work-size", type=int, default=512)
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    from pipeline.flare_rays import RayConfig
    from pipeline.images import read_image
    from pipeline.mask import ray_marks
    from pipeline.provenance import write_result

    rows = {}
    for photo in a.photos:
        img = read_image(photo, bgr=True)
        rows[photo.name] = {name: float(ray_marks(img, a.work_size, RayConfig(**kw)).mean())
                            for name, kw in SETTINGS.items()}
        print(photo.name, {k: f"{100 * v:.2f} %" for k, v in rows[photo.name].items()},
              flush=True)
    write_result(a.out, {"work_size": a.work_size, "settings": SETTINGS, "marked": rows})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
