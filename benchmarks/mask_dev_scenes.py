"""Benchmark of flare masks on real multi-view scenes with synthetic flare and true masks.

The FMG's own scores use single composites; this scores what the mask stage would write on
the photos of `deflare-scene synth` folders (their `photos/` and `masks_gt/`), for several
FMG weight files, with and without the flare rays (`mask --rays`): flare IoU and the share
of pixels marked outside the true flare, and per view the true and the marked share, with
how many views each would put over the 10 % target rule (`over_rule`, `true_over_rule`).
Use development scenes to choose.

    python benchmarks/mask_dev_scenes.py SYNTH [SYNTH ...] --weights A.safetensors \
        --weights B.safetensors --out docs/results/mask_dev_scenes.json

``--ray-rule MIN,OPP`` (repeatable) scores the rays under rules of their own, as `mask
--ray-min MIN --ray-opposite OPP` (e.g. ``--ray-rule 3,0 --ray-rule 3,8``: the stage's rule
and one that also keeps a lone streak through a light), the network run once for all;
``--streak-lines`` scores each ray setting again with the streak lines (`mask
--streak-lines`), ``--light-cores`` with lamps found by their core (`mask --light-cores`).
"""

from __future__ import annotations

import argparse
import itertools
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


BAND = 0.02
"""Width of the band around the true flare, as a share of the long side, inside which a
mark outside the flare counts as ``marked_near`` (a wider halo) rather than ``marked_far``."""


def near_band(truth: np.ndarray, band: float = BAND) -> np.ndarray:
    """Pixels within ``band`` x the long side of the true flare, the flare itself excluded."""
    import cv2

    r = max(1, round(band * max(truth.shape)))
    disk = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
    return (cv2.dilate(truth.astype(np.uint8), disk) > 0) & ~truth


def score_scene(model, cut: float, synth: Path, rays: bool, work_size: int = 512,
                max_size: int | None = None, fill_holes: bool = False, confirm=None,
                scales: tuple[float, ...] = (1.0,), ghosts=None, cache: dict | None = None,
                ray_cfg=None, pads: tuple[str, ...] = (), pads_keep: str = "pixels") -> dict:
    """Pooled flare IoU and marked-outside-truth share over the views of one synth folder,
    the latter split into a band around the flare (``marked_near``) and beyond it. With
    ``max_size`` each photo (area) and true mask (nearest) is first shrunk to that long side,
    as `decode --max-size` would; with ``fill_holes`` the masks as `mask --fill-holes` writes
    them; with ``confirm`` = (second model, its cut, keep) as `mask --confirm` writes them;
    with ``scales``, ``pads`` and ``pads_keep`` the network run as `mask --scales`, `--pads`
    and `--pads-keep` run it; with ``ghosts`` (a GhostConfig) the ghost-line regions added
    as `mask --ghost-lines` adds them. ``cache``
    (a dict kept per ``model``) holds each photo's probabilities and lights between calls, so
    that scoring the same photos with and without rays or ghost lines runs the network once;
    ``ray_cfg``: the rays' rule (a ``pipeline.flare_rays.RayConfig``; default the stage's)."""
    import cv2

    from pipeline.decode import resize_area, target_size
    from pipeline.images import list_photos, read_gray, read_image
    from pipeline.mask import flare_marks, fmg_probs, lights_at_work_size
    from pipeline.ws_files import enclosed_holes

    def pairs():
        for photo in list_photos(synth / "photos"):
            gt_path = next(iter(sorted((synth / "masks_gt").glob(photo.stem + ".*"))), None)
            if gt_path is None:
                continue
            img = read_image(photo, bgr=True)
            gt = read_gray(gt_path) > 127
            if max_size:
                img = resize_area(img, max_size)
                wh = target_size(gt.shape[1], gt.shape[0], max_size)
                gt = cv2.resize(gt.astype(np.uint8), wh, interpolation=cv2.INTER_NEAREST) > 0
            regions = bool(pads) and pads_keep == "regions"
            if cache is None:
                m = flare_marks(model, img, cut, work_size, rays, confirm=confirm,
                                scales=scales, ghosts=ghosts, ray_cfg=ray_cfg, pads=pads,
                                pads_keep=pads_keep)
            else:
                key = (str(photo), max_size, work_size)
                if (key, scales, pads) not in cache:
                    cache[key, scales, pads] = fmg_probs(model, [img], work_size, scales,
                                                         pads)[0]
                cores = ray_cfg is not None and ray_cfg.cores
                if (rays or ghosts is not None) and (key, cores) not in cache:
                    cache[key, cores] = lights_at_work_size(img, work_size, ray_cfg)
                if regions and (key, scales, ()) not in cache:
                    cache[key, scales, ()] = fmg_probs(model, [img], work_size, scales)[0]
                m = flare_marks(model, img, cut, work_size, rays,
                                probs=cache[key, scales, () if regions else pads],
                                consensus=cache[key, scales, pads] if regions else None,
                                confirm=confirm, scales=scales, ghosts=ghosts,
                                found=cache.get((key, cores)), ray_cfg=ray_cfg)
            if fill_holes:
                m |= enclosed_holes(m)
            yield photo.stem, m, gt

    return mask_scores(pairs())


def mask_scores(pairs) -> dict:
    """Pooled flare IoU, marked-outside-truth share (near the flare and beyond) and per-view
    shares of (stem, mask, true mask) triples ([H, W] bool each)."""
    from gnfr.view_sampler import is_target

    inter = union = outside = near = pixels = truth = views = 0
    per_view = {}
    for stem, m, gt in pairs:
        per_view[stem] = {"true": round(float(gt.mean()), 5), "marked": round(float(m.mean()), 5)}
        inter += int((m & gt).sum())
        union += int((m | gt).sum())
        outside += int((m & ~gt).sum())
        near += int((m & near_band(gt)).sum())
        pixels += gt.size
        truth += int(gt.sum())
        views += 1
    return {"views": views, "flare_iou": inter / max(union, 1),
            "marked_outside": outside / max(pixels, 1), "marked_near": near / max(pixels, 1),
            "marked_far": (outside - near) / max(pixels, 1), "truth_share": truth / max(pixels, 1),
            "over_rule": sum(not is_target(v["marked"]) for v in per_view.values()),
            "true_over_rule": sum(not is_target(v["true"]) for v in per_view.values()),
            "per_view": per_view}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", type=Path, nargs="+")
    ap.add_argument("--weights", type=Path, action="append", required=True)
    ap.add_argument("--max-size", type=int, default=None,
                    help="shrink photos and true masks to this long side first")
    ap.add_argument("--fill-holes", action="store_true", help="as `mask --fill-holes`")
    ap.add_argument("--confirm", type=Path, default=None,
                    help="as `mask --confirm --confirm-weights W`, for every --weights")
    ap.add_argument("--confirm-keep", choices=("both", "first"), default="both",
                    help="as `mask --confirm-keep`")
    ap.add_argument("--scales", action="append", default=None, metavar="S1,S2",
                    help="as `mask --scales` (repeat to score each setting; default 1)")
    ap.add_argument("--pads", action="append", default=None, metavar="MODES",
                    help="as `mask --pads` (e.g. reflect,replicate,constant; none: the plain "
                         "pass; repeat to score each setting; default none)")
    ap.add_argument("--pads-keep", choices=("pixels", "regions"), default="pixels",
                    help="as `mask --pads-keep` for every --pads setting")
    ap.add_argument("--ghost-lines", action="store_true",
                    help="also score each setting with `mask --ghost-lines`")
    ap.add_argument("--ray-rule", action="append", default=None, metavar="MIN,OPP",
                    help="score the rays with this rule, as `mask --ray-min MIN --ray-opposite "
                         "OPP` (repeat to score each; default the stage's)")
    ap.add_argument("--streak-lines", action="store_true",
                    help="also score each ray setting with `mask --streak-lines`")
    ap.add_argument("--light-cores", action="store_true",
                    help="also score each ray setting with `mask --light-cores`")
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    try:
        rules = [(int(m), float(o)) for m, o in (x.split(",") for x in a.ray_rule or [])]
    except ValueError:
        ap.error("--ray-rule: give MIN,OPP, e.g. 3,8")
    if any(m < 1 or not 0 <= o <= 90 for m, o in rules):
        ap.error("--ray-rule: MIN at least 1, OPP from 0 to 90 degrees")
    try:
        settings = [tuple(float(s) for s in x.split(",")) for x in a.scales or ["1"]]
    except ValueError:
        ap.error("--scales: give numbers separated by commas, e.g. 1,0.75")
    if any(s <= 0 or s > 2 for x in settings for s in x):
        ap.error("--scales: each number more than 0 and at most 2")
    pad_settings = [() if x == "none" else tuple(x.split(",")) for x in a.pads or ["none"]]
    if any(m not in ("reflect", "replicate", "constant") for x in pad_settings for m in x):
        ap.error("--pads: give none or paddings of reflect, replicate, constant separated by "
                 "commas")
    for scene in a.scenes:  # every folder checked before the slow scoring starts
        missing = [d for d in ("photos", "masks_gt") if not (scene / d).is_dir()]
        if missing:
            print(f"error: {scene}: no {missing[0]}/ folder; pass folders written by "
                  "`deflare-scene synth`", file=sys.stderr)
            return 2
    from pipeline.flare_ghosts import GhostConfig
    from pipeline.flare_rays import RayConfig
    from pipeline.mask import MaskConfig, load_fmg_weights, resolve_threshold
    from pipeline.provenance import sha256, write_result

    confirm = None
    if a.confirm is not None:
        confirm = (load_fmg_weights(a.confirm), resolve_threshold(MaskConfig(), a.confirm),
                   a.confirm_keep)
    rows = []
    for w in a.weights:
        model = load_fmg_weights(w)
        cache = {}  # each photo's probabilities under this model, and its lights
        cut = resolve_threshold(MaskConfig(), w)
        ghost_settings = (False, True) if a.ghost_lines else (False,)
        ray_settings = ([(False, None, False, False)]
                        + [(True, r, False, False) for r in rules or [None]]
                        + [(True, r, True, False) for r in (rules or [None]) if a.streak_lines]
                        + [(True, r, False, True) for r in (rules or [None]) if a.light_cores])
        for (rays, rule, lines, cores), scales, pads, ghost, scene in itertools.product(
                ray_settings, settings, pad_settings, ghost_settings, a.scenes):
            ray_cfg = RayConfig(**({} if rule is None else
                                   {"min_rays": rule[0], "opposite": rule[1]}), lines=lines,
                                cores=cores)
            r = {"weights": str(w), "sha256": sha256(w), "cut": cut, "rays": rays,
                 "ray_rule": None if rule is None else list(rule), "streak_lines": lines,
                 "light_cores": cores,
                 "scene": scene.name, "max_size": a.max_size, "fill_holes": a.fill_holes,
                 "confirm": None if confirm is None else str(a.confirm),
                 "confirm_keep": a.confirm_keep, "scales": list(scales), "pads": list(pads),
                 "pads_keep": a.pads_keep if pads else None,
                 "ghost_lines": ghost,
                 **score_scene(model, cut, scene, rays, max_size=a.max_size,
                               fill_holes=a.fill_holes, confirm=confirm, scales=scales,
                               ghosts=GhostConfig() if ghost else None, cache=cache,
                               ray_cfg=ray_cfg, pads=pads, pads_keep=a.pads_keep)}
            rows.append(r)
            print(f"{w.name} x{','.join(f'{s:g}' for s in scales)}"
                  f"{' pads ' + ','.join(pads) if pads else ''}"
                  f"{' ' + a.pads_keep if pads and a.pads_keep != 'pixels' else ''}"
                  f"{' +ghost-lines' if ghost else ''} "
                  f"{'rays' if rays else 'fmg '}{'' if rule is None else f' {rule[0]},{rule[1]:g}'}"
                  f"{' +streak-lines' if lines else ''}{' +light-cores' if cores else ''}"
                  f" {scene.name}: flare IoU "
                  f"{r['flare_iou']:.3f}, marked outside the flare "
                  f"{100 * r['marked_outside']:.2f} % (near {100 * r['marked_near']:.2f}, far "
                  f"{100 * r['marked_far']:.2f}; truth {100 * r['truth_share']:.2f} %); "
                  f"over the 10 % rule: {r['over_rule']} of {r['views']} views "
                  f"(truth {r['true_over_rule']})",
                  flush=True)
    write_result(a.out, {"rows": rows})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
