"""Flare masks the mask stage writes in posed workspaces of synth scenes, per mask setting.

`benchmarks/mask_dev_scenes.py` scores one photo at a time; a setting that asks the other
photos (`mask --crosscheck`, `mask --ghost-lines --ghost-views`) needs the views posed. For
each folder written by `deflare-scene synth` this poses its training photos with the true
cameras in WORK/<name>.ws (as the evaluation harness does), runs the mask stage there with
each setting and scores WS/masks against `masks_gt/`: rows in mask_dev_scenes.py's format
(flare IoU, marked outside the flare, per view), so that `mask_kind_scenes.py judge` reads
them (settings named ``fmg.safetensors@1``, ``...@1+ghosts+views``). With ``--clean`` the
workspaces hold the same views' clean photos (`SYNTH/clean/`, the light's core drawn in)
and every mark but the core is a false one: rows with the share each setting marks, and the
mean share the candidate adds over the base. ``--posed WS`` scores a posed workspace of
clean photos likewise (a real scene posed by `pose`; run in WORK/<name>.ws, sharing its
photos and cameras, so nothing is written into WS). Use development scenes to choose.

    python benchmarks/mask_views_scenes.py [SYNTH ...] [--posed WS [WS ...]] --work DIR \
        [--clean] [--weights W] [--pads reflect,replicate,constant | --light-cores |
        --fill-holes | --streak-lines [--streak-scales 1,0.25]] --out J
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

SETTINGS = {"base": {"ghost_lines": False, "ghost_views": False, "pads": ()},
            "ghost_views": {"ghost_lines": True, "ghost_views": True, "pads": ()}}
"""The mask settings scored (MaskConfig fields over its defaults): the network and its rays
(the stage's default up to the thirty-fifth session), and with the ghost-line candidates the
other photos confirm (its default from then to the seventy-second session; today's default
adds `--pads reflect,replicate,constant`, scored as the ``--pads`` candidate)."""


def score_workspace(synth: Path, work: Path, weights: Path, clean: bool,
                    posed: bool = False, settings: dict | None = None) -> list[dict]:
    """One row per setting of ``settings`` (default SETTINGS) for the synth folder ``synth``
    posed in ``work`` (or, ``posed``, the posed workspace ``synth`` of clean photos, shared
    into ``work``)."""
    from benchmarks.mask_dev_scenes import mask_scores
    from pipeline import mask
    from pipeline.provenance import sha256
    from pipeline.workspace import Workspace
    from pipeline.ws_files import read_cameras, read_mask, read_mask_file
    from workflows.research.eval.scene import load_synth
    from workflows.research.eval.workspaces import build_workspace, shared_workspace

    if posed:
        folder, clean = "posed", True
        base = Workspace(synth)
        base.require("pose")
        ws = shared_workspace(base, work / f"{synth.name}_posed.ws")
    else:
        folder = "clean" if clean else "photos"
        ws = build_workspace(load_synth(synth), work / f"{synth.name}_{folder}.ws",
                             folder=folder)
    stems = read_cameras(ws).stems
    cut = mask.resolve_threshold(mask.MaskConfig(), weights)
    rows = []
    for name, over in (settings or SETTINGS).items():
        config = mask.MaskConfig(weights=weights, **over)
        mask.run(config, ws)
        marks = {s: read_mask(ws, s) for s in stems}
        if clean:
            truth = {s: np.zeros(m.shape, bool) for s, m in marks.items()}
        else:
            truth = {s: read_mask_file(synth / "masks_gt" / f"{s}.png",
                                       size=(m.shape[1], m.shape[0]))
                     for s, m in marks.items()}
        rows.append({"weights": str(weights), "sha256": sha256(weights), "cut": cut,
                     "rays": True, "scene": synth.name, "folder": folder, "setting": name,
                     "scales": [1.0], "ghost_lines": config.ghost_lines,
                     "ghost_views": config.ghost_views, "ray_opposite": config.ray_opposite,
                     "streak_lines": config.streak_lines, "light_cores": config.light_cores,
                     "streak_scales": (list(config.streak_scales)
                                       if config.streak_scales is not None else None),
                     "fill_holes": config.fill_holes,
                     "pads": list(config.pads),
                     "pads_keep": config.pads_keep if config.pads else None,
                     "marked": float(np.mean([m.mean() for m in marks.values()])),
                     **mask_scores((s, marks[s], truth[s]) for s in stems)})
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", type=Path, nargs="*")
    ap.add_argument("--posed", type=Path, action="extend", nargs="+", default=[],
                    help="posed workspaces of clean photos (one or more; the flag may "
                         "repeat)")
    ap.add_argument("--work", type=Path, required=True,
                    help="folder for the posed workspaces (kept: a rerun resumes there)")
    ap.add_argument("--clean", action="store_true",
                    help="score the scenes' clean photos (every mark but the core is false)")
    ap.add_argument("--weights", type=Path, default=None)
    ap.add_argument("--ray-opposite", type=float, default=None, metavar="DEG",
                    help="also score the default setting with `mask --ray-opposite DEG` "
                         "(setting ghost_views_opp; `candidate_added`: its mean share over "
                         "ghost_views')")
    ap.add_argument("--streak-lines", action="store_true",
                    help="also score the default setting with `mask --streak-lines` "
                         "(setting ghost_views_lines; `candidate_added`: its mean share "
                         "over ghost_views')")
    ap.add_argument("--pads", default=None, metavar="MODES",
                    help="also score the ghost_views setting with `mask --pads MODES` (e.g. "
                         "reflect,replicate,constant; setting ghost_views_pads; "
                         "`candidate_added`: its mean share over ghost_views')")
    ap.add_argument("--pads-keep", choices=("pixels", "regions"), default="pixels",
                    help="with --pads: as `mask --pads-keep`")
    ap.add_argument("--light-cores", action="store_true",
                    help="score today's default (setting ghost_views_pads: the ghost lines "
                         "the other photos confirm, --pads reflect,replicate,constant) and it "
                         "with `mask --light-cores` (ghost_views_pads_cores), those two only; "
                         "`candidate_added`: the second's mean share over the first's")
    ap.add_argument("--fill-holes", action="store_true",
                    help="score today's default (ghost_views_pads, as with --light-cores) and "
                         "it with `mask --fill-holes` (ghost_views_pads_holes), those two only; "
                         "`candidate_added`: the second's mean share over the first's")
    ap.add_argument("--streak-scales", default=None, metavar="S1,S2",
                    help="with --streak-lines: score today's default with `mask "
                         "--streak-lines` (ghost_views_pads_lines) and with `--streak-scales "
                         "S1,S2` too (ghost_views_pads_lines_scaled), those two only; "
                         "`candidate_added`: the second's mean share over the first's")
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    scales = ()
    if a.streak_scales is not None:
        from pipeline.errors import UserError
        from pipeline.mask import MaskConfig, check_streak_scales, parse_streak_scales

        try:
            scales = parse_streak_scales(a.streak_scales)
            check_streak_scales(MaskConfig(streak_lines=a.streak_lines, streak_scales=scales))
        except UserError as e:
            ap.error(str(e))
    if sum((a.streak_lines, a.ray_opposite is not None, a.pads is not None,
            a.light_cores, a.fill_holes)) > 1:
        ap.error("give one candidate: --ray-opposite, --streak-lines, --pads, --light-cores "
                 "or --fill-holes")
    pads = tuple(a.pads.split(",")) if a.pads else ()
    if any(m not in ("reflect", "replicate", "constant") for m in pads):
        ap.error("--pads: paddings of reflect, replicate, constant separated by commas")
    if not a.scenes and not a.posed:
        ap.error("give synth folders, --posed workspaces, or both")
    if a.ray_opposite is not None and not 0 <= a.ray_opposite <= 90:
        ap.error("--ray-opposite: degrees from 0 to 90")
    settings = dict(SETTINGS)
    if a.ray_opposite is not None:
        settings["ghost_views_opp"] = {**SETTINGS["ghost_views"], "ray_opposite": a.ray_opposite}
    if a.streak_lines:
        settings["ghost_views_lines"] = {**SETTINGS["ghost_views"], "streak_lines": True}
    if pads:
        settings["ghost_views_pads"] = {**SETTINGS["ghost_views"], "pads": pads,
                                        "pads_keep": a.pads_keep}
    # today's default against it with one option more: (setting's suffix, MaskConfig field)
    today = {**SETTINGS["ghost_views"], "pads": ("reflect", "replicate", "constant")}
    extra = ("_cores", "light_cores", True) if a.light_cores else (
        ("_holes", "fill_holes", True) if a.fill_holes else None)
    if scales:  # today's default with the streak lines, and with them at these scales too
        today = {**today, "streak_lines": True}
        extra = ("_scaled", "streak_scales", scales)
    if extra:
        base = "ghost_views_pads" + ("_lines" if scales else "")
        settings = {base: today, base + extra[0]: {**today, extra[1]: extra[2]}}
    from workflows.threads import apply_thread_policy

    apply_thread_policy()  # before torch loads (workflows/threads.py)
    from pipeline.errors import UserError
    from pipeline.mask import DEFAULT_WEIGHTS
    from pipeline.provenance import write_result

    weights = (a.weights or DEFAULT_WEIGHTS).resolve()
    a.work.mkdir(parents=True, exist_ok=True)
    rows = []
    try:
        for scene, posed in [(s, False) for s in a.scenes] + [(w, True) for w in a.posed]:
            got = score_workspace(scene.resolve(), a.work, weights, a.clean, posed, settings)
            rows += got
            print(f"{scene.name} ({got[0]['folder']}): " + "; ".join(
                f"{r['setting']} flare IoU {r['flare_iou']:.3f}, marked "
                f"{100 * r['marked']:.3f} %" for r in got), flush=True)
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    out = {"weights": str(weights), "clean": a.clean, "settings": settings, "rows": rows}
    by = {name: [r for r in rows if r["setting"] == name] for name in settings}
    out["mean_marked"] = {n: float(np.mean([r["marked"] for r in v])) for n, v in by.items()}
    if "base" in settings:
        out["mean_added"] = out["mean_marked"]["ghost_views"] - out["mean_marked"]["base"]
    for cand in ("ghost_views_opp", "ghost_views_lines", "ghost_views_pads"):
        if cand in settings and "ghost_views" in settings:
            out["candidate_added"] = (out["mean_marked"][cand]
                                      - out["mean_marked"]["ghost_views"])
    if extra:
        out["candidate_added"] = (out["mean_marked"][base + extra[0]]
                                  - out["mean_marked"][base])
    out["max_view_marked"] = {n: max(v["marked"] for r in rs for v in r["per_view"].values())
                              for n, rs in by.items()}
    print(f"mean over {len(a.scenes) + len(a.posed)} scenes: marked " + ", ".join(
        f"{n} {100 * v:.3f} %" for n, v in out["mean_marked"].items()))
    write_result(a.out, out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
