"""Stage `select`: the View Sampler's rules, written to ``WS/views.json``.

```
{"max_flare": 0.1,
 "views": {"<stem>": {"flare_fraction": f, "target": bool,
                      "sources": [{"stem": s, "distance": d, "flare_fraction": f}, ...]}}}
```
A view whose flare occupancy is above ``max_flare`` is never a training target (it can
still be rendered as a novel view and still serve as a source where it is clean). Each
view's ``sources`` lists every OTHER view, nearest camera centre first; training and
rendering pick among the nearest with ``gnfr.view_sampler.pick_sources`` (the least
flared, fractions within its tolerance counting as equal and the nearer winning).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pipeline.cameras import load_cameras
from pipeline.errors import UserError
from pipeline.options import option, validate
from pipeline.progress import info
from pipeline.workspace import Workspace, atomic_write_json, read_json


@dataclass
class SelectConfig:
    """Options of the select stage."""

    max_flare: float = option(0.10, ge=0, le=1)
    """Views whose flare fraction is above this are never training targets (paper: 10%)."""
    min_targets: int = option(2, ge=1)
    """Fewest target-eligible views the scene needs."""


def rank_sources(centers: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For camera centres [N, 3]: order [N, N-1] of the other views nearest first, and
    their distances [N, N-1]. Ties keep the input order (stable sort)."""
    d = np.linalg.norm(centers[:, None, :] - centers[None, :, :], axis=-1)   # [N, N]
    n = len(centers)
    order = np.empty((n, max(n - 1, 0)), int)
    for i in range(n):
        others = np.array([j for j in range(n) if j != i], int)
        order[i] = others[np.argsort(d[i, others], kind="stable")]
    return order, np.take_along_axis(d, order, axis=1)


def build_views(stems: list[str], centers: np.ndarray, fractions: dict[str, float],
                max_flare: float) -> dict:
    """The views.json object for views ``stems`` with camera centres [N, 3]."""
    order, dist = rank_sources(np.asarray(centers, float))
    views = {}
    for i, s in enumerate(stems):
        views[s] = {
            "flare_fraction": fractions[s],
            "target": bool(fractions[s] <= max_flare),
            "sources": [{"stem": stems[j], "distance": round(float(dd), 6),
                         "flare_fraction": fractions[stems[j]]}
                        for j, dd in zip(order[i], dist[i], strict=True)],
        }
    return {"max_flare": max_flare, "views": views}


def check_targets(views: dict, max_flare: float, min_targets: int, root: Path) -> None:
    """UserError naming the flared views when fewer than ``min_targets`` are eligible."""
    targets = [s for s, v in views["views"].items() if v["target"]]
    if len(targets) >= min_targets:
        return
    flared = ", ".join(f"{s} ({100 * v['flare_fraction']:.1f}%)"
                       for s, v in sorted(views["views"].items(),
                                          key=lambda kv: -kv[1]["flare_fraction"])
                       if not v["target"])
    raise UserError(
        f"only {len(targets)} of {len(views['views'])} views have at most "
        f"{100 * max_flare:.0f}% flare (need {min_targets}); flared: {flared}. Retake "
        f"some photos with less flare, raise --max-flare, or give hand-made masks with "
        f"`deflare-scene mask {root} --masks DIR`")


def run(config: SelectConfig, ws: Workspace, force: bool = False) -> list[Path]:
    """Write WS/views.json; returns the written paths."""
    validate(config)
    ws.require("pose", "mask")
    run_ = ws.begin_stage("select", {"max_flare": config.max_flare,
                                     "min_targets": config.min_targets},
                          [ws.cameras_json, ws.flare_json], force)
    if run_.skip:
        info(f"select: up to date ({ws.views_json})")
        return run_.outputs
    cams = load_cameras(ws.cameras_json)
    flare = read_json(ws.flare_json).get("views", {})
    missing = [s for s in cams.stems if s not in flare]
    if missing:
        raise UserError(f"{ws.flare_json} has no flare fraction for view(s) "
                        f"{', '.join(missing)}: rerun `deflare-scene mask {ws.root} --force`")
    fractions = {s: float(flare[s]["flare_fraction"]) for s in cams.stems}
    views = build_views(cams.stems, cams.centers(), fractions, config.max_flare)
    check_targets(views, config.max_flare, config.min_targets, ws.root)
    atomic_write_json(ws.views_json, views)
    n_t = sum(v["target"] for v in views["views"].values())
    info(f"select: {n_t} of {len(views['views'])} views are training targets "
         f"(flare <= {100 * config.max_flare:.0f}%)")
    return run_.finish([ws.views_json], extra={"targets": n_t})
