"""The one-shot pipeline: every stage in order on one photo folder, each resumable.

``deflare-scene ./photos`` runs decode, pose, mask, depth, select, finetune, render (the input
views and the video path) and export. Each stage skips itself when its inputs and
parameters did not change, so rerunning the same command after an interruption picks up
where it stopped; changing an option reruns that stage and everything after it.

The common options are flags of the command; every other field of every stage's config is
reachable with ``--set STAGE.FIELD=VALUE`` (e.g. ``--set finetune.rays=512``).
"""

from __future__ import annotations

import importlib
import time
import typing
from dataclasses import dataclass, field, fields, is_dataclass, replace
from pathlib import Path
from typing import Any

from pipeline.errors import UserError
from pipeline.options import check_field, coerce, resolve_device, validate
from pipeline.progress import info
from pipeline.workspace import default_workspace

STAGES = {
    "decode": "pipeline.decode:DecodeConfig", "pose": "pipeline.pose:PoseConfig",
    "mask": "pipeline.mask:MaskConfig", "depth": "pipeline.depth:DepthConfig",
    "select": "pipeline.select:SelectConfig", "finetune": "pipeline.finetune:FinetuneConfig",
    "render": "pipeline.render.config:RenderConfig", "export": "pipeline.export:ExportConfig",
}
"""The config class ("module:Class") of every stage the one-shot runs, in order."""
DEFAULTS = {"render": {"path": "interpolate"}}
"""Where the one-shot's defaults differ from the stage command's."""


def _stage_configs() -> dict[str, Any]:
    """Default config of every stage the one-shot runs, by stage name."""
    out = {}
    for stage, target in STAGES.items():
        module, _, cls = target.partition(":")
        out[stage] = getattr(importlib.import_module(module), cls)(**DEFAULTS.get(stage, {}))
    return out


@dataclass
class OneShotConfig:
    """Options of `deflare-scene PHOTOS` (the one-shot command)."""

    photos: Path
    """Folder of photos (only read, never written)."""
    out: Path | None = None
    """Workspace folder; default ``<photos>.deflare`` beside the photo folder."""
    stages: dict[str, Any] = field(default_factory=_stage_configs)
    """Config of each stage by name (decode, pose, mask, depth, select, finetune, render,
    export)."""
    force: bool = False
    """Rerun every stage even when its inputs did not change."""


def default_fps(device: str) -> float:
    """Video frame rate when none is given: 24 on CUDA, 12 on CPU (half the frames to render;
    a CPU renders about 2-4 thousand rays a second with the quick preset)."""
    try:
        return 24.0 if resolve_device(device).startswith("cuda") else 12.0
    except UserError:  # a bad --device: the option check reports it before anything runs
        return 24.0


# --------------------------------------------------------------------------- --set parsing
def apply_overrides(stages: dict[str, Any], items: list[str]) -> dict[str, Any]:
    """Apply ``STAGE.FIELD=VALUE`` strings to the stage configs (new objects returned); each
    value is parsed and checked as the stage's own option is (``pipeline.options``)."""
    stages = dict(stages)
    for item in items:
        key, sep, value = item.partition("=")
        stage, dot, name = key.partition(".")
        if not sep or not dot:
            raise UserError(f"--set {item!r}: use STAGE.FIELD=VALUE, e.g. finetune.iters=2000")
        if stage not in stages:
            raise UserError(f"--set {item!r}: unknown stage {stage!r}; one of "
                            f"{', '.join(stages)}")
        cfg = stages[stage]
        names = {f.name for f in fields(cfg)}
        if name not in names:
            raise UserError(f"--set {item!r}: {stage} has no option {name!r}; it has "
                            f"{', '.join(sorted(names))}")
        hints = typing.get_type_hints(type(cfg))
        if is_dataclass(hints[name]):
            raise UserError(f"--set {item!r}: {stage}.{name} is a group of options; set its "
                            "fields with the stage's own command")
        form = next(f for f in fields(cfg) if f.name == name).metadata.get("metavar")
        cfg = replace(cfg, **{name: coerce(value, hints[name], f"--set {item}", form)})
        check_field(cfg, name, f"--set {item}")
        stages[stage] = cfg
    return stages


# --------------------------------------------------------------------------- the run
def resume_target(photos: Path, out: str | None, ws_path: Path) -> tuple[Path, Path]:
    """(photos, workspace) to run on: as given, or, when ``photos`` is itself a workspace,
    the photo folder it was made from and that workspace (`deflare-scene WS` resumes it)."""
    from pipeline.errors import shell_path
    from pipeline.workspace import enclosing_workspace

    found = enclosing_workspace(photos)
    if found is None or found[0] != photos.resolve():
        return photos, ws_path  # a folder inside a workspace: decode says what to pass
    root, source = found
    if out and Path(out).resolve() != root:
        raise UserError(f"{photos} is a deflare-scene workspace and --out names another: pass "
                        f"the photo folder it was made from ({source}) with --out {out}")
    if not source.is_dir():
        raise UserError(f"{photos} is the workspace of {source}, which is no longer there: "
                        "put the photos back there, or run `deflare-scene PHOTOS --out "
                        f"{shell_path(photos)}` with the folder where they are now")
    info(f"{photos} is the workspace of {source}: resuming it")
    return source, root


def run_all(cfg: OneShotConfig) -> Path:
    """Run every stage in order; return the workspace path."""
    for stage_cfg in cfg.stages.values():  # every option checked before anything is written
        validate(stage_cfg)  # ranges, and the rules between options (depth.sgm's P1 <= P2,
        # mask --ghost-views with --masks ...)
    photos = Path(cfg.photos)
    if not photos.exists():
        raise UserError(f"photo folder {photos} does not exist: pass a folder of photos, "
                        "e.g. `deflare-scene ./photos`, or see `deflare-scene --help`")
    from pipeline import decode, depth, export, finetune, mask, pose, render, select

    decode.require_folder(photos)

    stages, force, t0 = cfg.stages, cfg.force, time.time()
    ws_path = Path(cfg.out) if cfg.out else default_workspace(photos)
    photos, ws_path = resume_target(photos, cfg.out, ws_path)
    ws = decode.run(stages["decode"], photos, ws_path, force=force)
    pose.run(stages["pose"], ws, force=force)
    mask.run(stages["mask"], ws, force=force)
    depth.run(stages["depth"], ws, force=force)
    select.run(stages["select"], ws, force=force)
    finetune.run(stages["finetune"], ws, force=force)
    # the de-flared photos first (the video's frames may read them), without the options
    # that are the frames' alone
    render.run(replace(stages["render"], path="inputs", from_deflared=False,
                       lean_deflared=False, source_grow=0.0), ws, force=force)
    render.run(stages["render"], ws, force=force)
    path = Path(stages["render"].path).stem
    written = export.run(replace(stages["export"], path=path), ws, force=force)
    video = ws.video_of(path)
    minutes = (time.time() - t0) / 60
    info(f"[green]done[/green] in {minutes:.1f} min: workspace {ws.root}")
    info(f"  de-flared photos: {ws.deflared}")
    if video.exists():
        info(f"  video: {video}")
    for path in written:
        if path != video and path.suffix in (".mp4", ".jpg", ".glb", ".json", ".ply"):
            info(f"  {path.name}: {path}")
    return ws.root
