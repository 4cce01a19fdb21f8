"""How bright the true flare is against its background: FMG composites against synth scenes.

    python benchmarks/flare_contrast.py --scenes DIR [--count 48] [--data SHARED] --out JSON

A diagnosis for the mask network (docs/history/fmg.md, "Thirty-first session"): per kind of
flare, the percentiles (10, 25, 50, 75) over the true mask's pixels of the flare's added
linear luminance, absolute and relative to the background's, on (a) ``--count`` daylight
development composites of that kind alone (256 px, the flare drawn for the composite, as
`fmg eval --per-kind --split dev --night 0` draws them, with its own seed), and (b) the
one-kind scenes of ``benchmarks/mask_kind_scenes.py build`` under ``--scenes``
(``<scene>_<kind>/photos`` against ``clean``, over ``masks_gt``). If the scenes' flare
were fainter than the composites', that would explain why the FMG finds less of it there.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

PERCENTILES = (10, 25, 50, 75)


def luminance(rgb: np.ndarray) -> np.ndarray:
    """Linear-light luminance (Rec. 709) of [..., 3] linear RGB."""
    return rgb @ np.array([0.2126, 0.7152, 0.0722], np.float32)


def contrast(flared_lin: np.ndarray, clean_lin: np.ndarray, mask: np.ndarray):
    """(absolute, relative) added luminance over the pixels of ``mask``."""
    a, b = luminance(flared_lin), luminance(clean_lin)
    return (a - b)[mask], ((a - b) / np.maximum(b, 1e-3))[mask]


def summary(parts: list[np.ndarray]) -> dict:
    v = np.concatenate(parts) if parts else np.zeros(0)
    return {"pixels": int(v.size), **{f"p{q}": float(np.percentile(v, q)) if v.size else None
                                      for q in PERCENTILES}}


def dev_backgrounds(data: Path) -> list:
    """The development backgrounds, loaded as the composites load them."""
    from pipeline.fmg_data import CompositeConfig, load_backgrounds, split_backgrounds

    return load_backgrounds(split_backgrounds(data).dev, CompositeConfig().preload_side)


def composites(kind: str, bgs: list, count: int, seed: int = 7) -> dict:
    """Contrast on ``count`` daylight composites of ``kind`` alone on the backgrounds
    ``bgs`` (:func:`dev_backgrounds`)."""
    from pipeline import flare as fl
    from pipeline.colour import srgb_to_linear
    from pipeline.fmg_data import CompositeConfig, composite_flare, random_crop

    comp = CompositeConfig(size=256)
    cfg, rng = fl.FlareConfig(kinds=(kind,)), np.random.default_rng(seed)
    absolute, relative = [], []
    for _ in range(count):
        bg = random_crop(bgs[int(rng.integers(len(bgs)))], comp.size, comp.crop_scale, rng)
        flared, mask = composite_flare(bg, cfg, comp, rng)
        a, r = contrast(srgb_to_linear(flared), srgb_to_linear(bg), mask)
        absolute.append(a)
        relative.append(r)
    return {"absolute": summary(absolute), "relative": summary(relative)}


def scenes(kind: str, root: Path) -> dict:
    """Contrast on every view of the one-kind scenes ``root/*_<kind>``."""
    from pipeline.colour import srgb_to_linear
    from pipeline.images import read_image_float
    from pipeline.ws_files import read_mask_file

    absolute, relative, names = [], [], []
    for d in sorted(root.glob(f"*_{kind}")):
        names.append(d.name)
        for photo in sorted((d / "photos").glob("*.png")):
            truth_file, clean_file = d / "masks_gt" / photo.name, d / "clean" / photo.name
            if not (truth_file.is_file() and clean_file.is_file()):
                continue
            truth = read_mask_file(truth_file)
            if not truth.any():
                continue
            a, r = contrast(srgb_to_linear(read_image_float(photo)),
                            srgb_to_linear(read_image_float(clean_file)), truth)
            absolute.append(a)
            relative.append(r)
    return {"scenes": names, "absolute": summary(absolute), "relative": summary(relative)}


def main(argv: list[str] | None = None) -> int:
    from pipeline.errors import UserError
    from pipeline.flare import KINDS
    from workflows.research.fmg_eval import default_data

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=Path, required=True,
                    help="the folder of benchmarks/mask_kind_scenes.py build")
    ap.add_argument("--count", type=int, default=48)
    ap.add_argument("--data", type=Path, default=None)
    ap.add_argument("--out", type=Path)
    a = ap.parse_args(argv)
    res = {}
    try:
        if not any((d / "photos").is_dir() for k in KINDS for d in a.scenes.glob(f"*_{k}")):
            raise UserError(f"{a.scenes}: no one-kind scenes (<scene>_<kind>); build them with "
                            "benchmarks/mask_kind_scenes.py build")
        bgs = dev_backgrounds(a.data or default_data())
        for kind in KINDS:
            res[kind] = {"composites": composites(kind, bgs, a.count),
                         "scenes": scenes(kind, a.scenes)}
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    for kind, r in res.items():
        def med(src: str, what: str, r=r) -> str:
            v = r[src][what]["p50"]
            return "-" if v is None else f"{v:.3f}"

        cells = [f"{src} rel {med(src, 'relative')} abs {med(src, 'absolute')}"
                 for src in ("composites", "scenes")]
        print(f"{kind:>9}: median " + "; ".join(cells))
    if a.out:
        from pipeline.provenance import write_result
        write_result(a.out, {"count": a.count, "percentiles": list(PERCENTILES), "kinds": res})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
