"""Time of the FMG network per view, for each weight file, on a folder of photos.

    python benchmarks/mask_time.py PHOTOS --weights A.safetensors --weights B.safetensors \
        [--work-size 512] [--repeat 2] [--out JSON]

Each photo is read as the mask stage reads a decoded view (BGR) and passed through
``pipeline.mask.fmg_probs`` alone, one view per call, after one warm-up view: the network's
share of the mask stage (the flare rays and file writing are the same for every file). The
thread count is the process's (set OMP_NUM_THREADS to compare like with like). ``--rays``
also times the flare rays per view (``pipeline.mask.ray_marks``, the lights found each
time), with the stage's rule and with the streak lines (`mask --streak-lines`): rows with
``rays`` set instead of weights; with ``--streak-scales S1,S2`` a third, the streak lines at
those scales too (`mask --streak-scales`). ``--pads MODES`` also times each file as `mask
--pads MODES` runs it (rows with ``pads`` set).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("photos", type=Path)
    ap.add_argument("--weights", type=Path, action="append", required=True)
    ap.add_argument("--work-size", type=int, default=512)
    ap.add_argument("--pads", default=None, metavar="MODES",
                    help="also time each file with `mask --pads MODES` (e.g. "
                         "reflect,replicate,constant)")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--rays", action="store_true",
                    help="also time the flare rays, without and with the streak lines")
    ap.add_argument("--streak-scales", default=None, metavar="S1,S2",
                    help="with --rays: also time the streak lines at these scales")
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    scales = None
    if a.streak_scales is not None:
        from pipeline.errors import UserError
        from pipeline.mask import parse_streak_scales

        if not a.rays:
            ap.error("--streak-scales times the rays' streak lines: add --rays")
        try:
            scales = parse_streak_scales(a.streak_scales)
        except UserError as e:
            ap.error(str(e))
    import torch

    from pipeline.errors import UserError
    from pipeline.flare_rays import RayConfig
    from pipeline.images import list_photos, read_image
    from pipeline.mask import fmg_probs, load_fmg_weights, ray_marks
    from pipeline.provenance import sha256, write_result

    paths = list_photos(a.photos) if a.photos.is_dir() else []
    try:
        if not paths:
            what = "no photos in this folder" if a.photos.is_dir() else "no such folder"
            raise UserError(f"{a.photos}: {what}; pass a folder of photos (e.g. a "
                            "workspace's decoded/)")
        images = [read_image(p, bgr=True) for p in paths]
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2

    def per_view(run) -> dict:
        """``run`` timed on each image, ``repeat`` times over: the row's sizes and times."""
        times = []
        for _ in range(a.repeat):
            for im in images:
                t0 = time.perf_counter()
                run(im)
                times.append(time.perf_counter() - t0)
        times.sort()
        return {"views": len(images), "view_size": list(images[0].shape[1::-1]),
                "work_size": a.work_size, "threads": torch.get_num_threads(),
                "median_s_per_view": round(times[len(times) // 2], 4),
                "mean_s_per_view": round(sum(times) / len(times), 4)}

    rows = []
    pad_settings = [()] + ([tuple(a.pads.split(","))] if a.pads else [])
    for w, pads in ((w, pads) for w in a.weights for pads in pad_settings):
        model = load_fmg_weights(w)
        params = sum(p.numel() for p in model.parameters())
        fmg_probs(model, images[:1], a.work_size, pads=pads)  # warm-up
        row = {"weights": str(w), "sha256": sha256(w), "parameters": params,
               "pads": list(pads),
               **per_view(lambda im, m=model, p=pads: fmg_probs(m, [im], a.work_size,
                                                                pads=p))}
        rows.append(row)
        print(f"{w.name}{' pads ' + ','.join(pads) if pads else ''}: {params / 1e6:.2f} M "
              f"parameters, {row['median_s_per_view']:.3f} s per "
              f"{row['view_size'][0]}x{row['view_size'][1]} view (median of "
              f"{a.repeat * len(images)}, {row['threads']} thread(s))", flush=True)
    rules = [("default", RayConfig()), ("streak_lines", RayConfig(lines=True))]
    if scales:
        rules.append(("streak_lines_at_" + ",".join(f"{v:g}" for v in scales),
                      RayConfig(lines=True, line_scales=scales)))
    for name, cfg in (rules if a.rays else ()):
        row = {"rays": name,
               **per_view(lambda im, c=cfg: ray_marks(im, a.work_size, c))}
        rows.append(row)
        print(f"rays ({row['rays']}): {row['median_s_per_view']:.3f} s per view (median of "
              f"{a.repeat * len(images)}, mean {row['mean_s_per_view']:.3f})", flush=True)
    write_result(a.out, {"photos": str(a.photos), "rows": rows})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
