"""Evidence across views the other way: drop FMG marks the neighbouring photos confirm as scene.

    python benchmarks/flare_veto.py --scene SYNTH [--scene SYNTH ...] [--clean WS ...] \
        [--depth-set depth.FIELD=VALUE ...] \
        --work DIR [--out JSON]

Flare moves with the camera; the scene does not. ``benchmarks/flare_evidence.py`` looked
for flare the FMG misses (view brighter than what its neighbours agree the scene looks
like) and failed: plane-sweep depth misregisters texture by more than faint flare adds
(docs/depth.md). This asks the converse question, where misregistration errs on the safe
side: a region the FMG marks in a view, whose unmarked neighbours (warped through their
depth, their own masks respected, gains matched: ``flare_evidence.consensus``) agree on the
scene's colour there and see it as bright as the view, is scene the FMG marked in this view
alone (a false mark), and is dropped. A region is dropped when at least ``min_judged`` of
its pixels have ``min_support`` agreeing neighbours and at least ``min_confirmed`` of those
are no brighter than the (max-filtered) consensus by more than the synthesizer's own mask
rule (``max(abs_threshold, rel_threshold x consensus)`` in linear luminance). Flare the
neighbours also carry and also mark is never judged (their marks are excluded), so it stays.

Per SYNTH scene (a `deflare-scene synth` folder, posed with its true cameras, `mask` and
`depth` with their defaults in DIR): flare IoU, mIoU, mAcc and the share marked outside the
flare, pooled over the flared views, for the FMG and after each veto setting; per clean
posed workspace WS (copied into DIR first, nothing of it is changed): the share of pixels
marked (every one a false mark), mean and max over views.
"""

from __future__ import annotations

import argparse
import itertools
import shutil
import sys
from dataclasses import asdict
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from flare_evidence import (  # noqa: E402  (benchmarks/ is not a package)
    EvidenceConfig,
    _confusion,
    _scores,
    clean_stats,
    flared_views,
    prepare,
    view_data,
)

from pipeline.crosscheck import CrosscheckRule, drop_confirmed  # noqa: E402

SWEEP = {"min_support": (2, 3), "min_judged": (0.3, 0.6), "min_confirmed": (0.6, 0.8, 0.95)}
"""The settings tried (every combination); the other fields keep the defaults of
``CrosscheckRule`` as they were when the rule was scored (abs 0.012, rel 0.1, slack 2)."""


def settings() -> list[CrosscheckRule]:
    keys = list(SWEEP)
    return [CrosscheckRule(**dict(zip(keys, v, strict=True)))
            for v in itertools.product(*SWEEP.values())]


def _more(c: np.ndarray) -> dict:
    """From a confusion matrix: the share of all pixels marked outside the flare, and the
    share of the true flare marked (recall)."""
    return {"outside": round(float(c[0, 1] / max(c.sum(), 1)), 5),
            "recall": round(float(c[1, 1] / max(c[1].sum(), 1)), 5)}


def score_scene(root: Path, work: Path, cfgs: list[CrosscheckRule], depth_cfg=None) -> dict:
    """Pooled over the flared views of a synth scene: the FMG's scores and each setting's."""
    fmg_c = np.zeros((2, 2), np.int64)
    cut_c = np.zeros((len(cfgs), 2, 2), np.int64)
    views = 0
    for fmg, cons, gt in flared_views(root, work, EvidenceConfig(), depth_cfg):
        views += 1
        fmg_c += _confusion(fmg, gt)
        for i, cfg in enumerate(cfgs):
            cut_c[i] += _confusion(drop_confirmed(fmg, cons, cfg), gt)
    return {"views": views, "fmg": {**_scores(fmg_c), **_more(fmg_c)},
            "settings": [{"config": asdict(c), "veto": {**_scores(cut_c[i]), **_more(cut_c[i])}}
                         for i, c in enumerate(cfgs)]}


def score_clean(path: Path, work: Path, cfgs: list[CrosscheckRule], depth_cfg=None) -> dict:
    """Share of pixels marked on a clean posed workspace (a copy in ``work``): the FMG's
    and each setting's (mean and max over views, views over 10 %)."""
    from pipeline.workspace import Workspace

    copy = work / f"{path.name}.clean.ws"
    if not copy.is_dir():
        tmp = copy.with_suffix(".tmp")
        shutil.rmtree(tmp, ignore_errors=True)
        shutil.copytree(path, tmp, symlinks=True)
        tmp.rename(copy)
    ws = Workspace(copy)
    prepare(ws, depth_cfg)

    data = view_data(ws, EvidenceConfig())
    return {"fmg": clean_stats([float(m.mean()) for m, _ in data.values()]),
            "settings": [{"config": asdict(cfg),
                          "veto": clean_stats([float(drop_confirmed(m, c, cfg).mean())
                                         for m, c in data.values()])} for cfg in cfgs]}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", type=Path, action="append", default=[])
    ap.add_argument("--clean", type=Path, action="append", default=[])
    ap.add_argument("--work", type=Path, required=True)
    ap.add_argument("--out", type=Path)
    ap.add_argument("--depth-set", action="append", default=[], metavar="depth.FIELD=VALUE",
                    help="an option of the depth stage whose maps the veto warps through, "
                         "e.g. depth.sgm=0.1,1")
    a = ap.parse_args(argv)
    from workflows.threads import apply_thread_policy

    apply_thread_policy()  # before torch loads (workflows/threads.py)
    from pipeline.depth import DepthConfig
    from pipeline.errors import UserError
    from pipeline.options import validate
    from pipeline.provenance import write_result
    from workflows.oneshot import apply_overrides

    try:  # every input checked before the first scene's stages run
        depth_cfg = validate(apply_overrides({"depth": DepthConfig()}, a.depth_set)["depth"])
        for root in a.scene:
            if not (root / "masks_gt").is_dir():
                raise UserError(f"{root}: not a synth scene (no masks_gt/): pass a folder "
                                "made by `deflare-scene synth`")
        for ws in a.clean:
            if not (ws / "cameras.json").is_file():
                raise UserError(f"{ws}: not a posed workspace (no cameras.json): run "
                                f"`deflare-scene pose {ws}` first")
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2

    cfgs = settings()
    a.work.mkdir(parents=True, exist_ok=True)
    res = {"sweep": {k: list(v) for k, v in SWEEP.items()}, "depth_sets": a.depth_set,
           "scenes": {}, "clean": {}}
    for root in a.scene:
        r = res["scenes"][root.name] = score_scene(root.resolve(), a.work, cfgs, depth_cfg)
        print(f"{root.name} ({r['views']} flared views): FMG flare IoU "
              f"{r['fmg']['IoU_flare']:.3f}, outside {100 * r['fmg']['outside']:.2f} %, recall "
              f"{r['fmg']['recall']:.3f}")
        for x in r["settings"]:
            print(f"  {x['config']}: IoU {x['veto']['IoU_flare']:.3f}, outside "
                  f"{100 * x['veto']['outside']:.2f} %, recall {x['veto']['recall']:.3f}")
    for ws in a.clean:
        r = res["clean"][ws.name] = score_clean(ws.resolve(), a.work, cfgs, depth_cfg)
        print(f"{ws.name} (clean): FMG marks {100 * r['fmg']['mean']:.2f} % "
              f"(max {100 * r['fmg']['max']:.2f})")
        for x in r["settings"]:
            print(f"  {x['config']}: {100 * x['veto']['mean']:.2f} % "
                  f"(max {100 * x['veto']['max']:.2f})")
    if a.out:
        write_result(a.out, res)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
