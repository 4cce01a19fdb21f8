"""Stage `select`: the View Sampler's rules, written to ``WS/views.json``.

Per view (format: ``pipeline.ws_files.ViewsFile``, docs/design.md): its flare fraction, its
``target`` flag (flare at most ``max_flare``: what finetune trains on) and every OTHER view
as a source, nearest camera centre first. A flared view can still be rendered and still
serve as a source where it is clean; training and rendering choose among the nearest
sources with ``gnfr.view_sampler.pick_sources``.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from pipeline.errors import UserError, shell_path
from pipeline.options import option, validate
from pipeline.progress import info, warn
from pipeline.workspace import Workspace
from pipeline.ws_files import (
    ViewsFile,
    is_target,
    make_views,
    rank_sources,
    read_cameras,
    read_flare,
    write_views,
)

__all__ = ["SelectConfig", "build_views", "check_targets", "few_targets_note", "rank_sources",
           "run"]

NOTE_MAX_FLARE = 0.15
"""The looser rule :func:`few_targets_note` counts for (docs/history/fmg.md,
"Twenty-eighth session")."""


@dataclass
class SelectConfig:
    """Options of the select stage."""

    max_flare: float = option(0.10, ge=0, le=1)
    """Views whose flare fraction is above this are never training targets (paper: 10%)."""
    min_targets: int = option(2, ge=1)
    """Fewest target-eligible views the scene needs."""


def build_views(stems: list[str], centers: np.ndarray, fractions: dict[str, float],
                max_flare: float) -> dict:
    """The views.json object (JSON) for views ``stems`` with camera centres [N, 3]
    (``pipeline.ws_files.make_views``)."""
    return make_views(stems, centers, fractions, max_flare).to_json()


def check_targets(views: ViewsFile, max_flare: float, min_targets: int, root: Path) -> None:
    """UserError naming the flared views when fewer than ``min_targets`` are eligible."""
    targets = views.targets()
    if len(targets) >= min_targets:
        return
    flared = ", ".join(f"{s} ({100 * v.flare_fraction:.1f}%)"
                       for s, v in sorted(views.views.items(),
                                          key=lambda kv: -kv[1].flare_fraction)
                       if not v.target)
    raise UserError(
        f"only {len(targets)} of {len(views.views)} views have at most "
        f"{100 * max_flare:.0f}% flare (need {min_targets}); flared: {flared}. Retake "
        f"some photos with less flare, raise --max-flare, or give hand-made masks with "
        f"`deflare-scene mask {shell_path(root)} --masks DIR`")


def few_targets_note(views: ViewsFile, max_flare: float, root: Path) -> str | None:
    """A note for a capture where fewer than half the views may train (most are marked
    over ``max_flare``): how many a looser rule (``NOTE_MAX_FLARE``) would train on and the
    command; None when half or more are targets or the looser rule adds none. The default
    rule stays the paper's: the trade-off is the user's."""
    n_t, n = len(views.targets()), len(views.views)
    looser = sum(is_target(v.flare_fraction, NOTE_MAX_FLARE) for v in views.views.values())
    if 2 * n_t >= n or max_flare >= NOTE_MAX_FLARE or looser <= n_t:
        return None
    return (f"only {n_t} of {n} views may be training targets: the other {n - n_t} have "
            f"more than {100 * max_flare:.0f}% of their pixels marked as flare (the paper's "
            f"rule), and fewer targets train a softer scene. "
            f"`deflare-scene select {shell_path(root)} --max-flare "
            f"{NOTE_MAX_FLARE}` would train on {looser} (in one shot: "
            f"`--set select.max_flare={NOTE_MAX_FLARE}`); their marked flare stays out of "
            f"the loss")


def run(config: SelectConfig, ws: Workspace, force: bool = False) -> list[Path]:
    """Write WS/views.json; returns the written paths."""
    validate(config)
    ws.require("pose", "mask")
    stage_run = ws.begin_stage("select", asdict(config), [ws.cameras_json, ws.flare_json],
                               force, defaults=asdict(SelectConfig()))
    if stage_run.skip:
        info(f"select: up to date ({ws.views_json})")
        return stage_run.outputs
    cams = read_cameras(ws)
    flare = read_flare(ws).fractions()
    missing = [s for s in cams.stems if s not in flare]
    if missing:
        raise UserError(f"{ws.flare_json} has no flare fraction for view(s) "
                        f"{', '.join(missing)}: {ws.rerun('mask')}")
    fractions = {s: flare[s] for s in cams.stems}
    views = make_views(cams.stems, cams.centers(), fractions, config.max_flare)
    check_targets(views, config.max_flare, config.min_targets, ws.root)
    write_views(ws, views)
    n_t = len(views.targets())
    info(f"select: {n_t} of {len(views.views)} views are training targets "
         f"(flare <= {100 * config.max_flare:.0f}%)")
    note = few_targets_note(views, config.max_flare, ws.root)
    if note:
        warn(note)
    return stage_run.finish([ws.views_json], extra={"targets": n_t})
