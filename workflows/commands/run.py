"""`deflare-scene run PHOTOS` (also plain `deflare-scene PHOTOS`): the whole pipeline."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import typer

from workflows.config_cli import Pick, fields_command
from workflows.oneshot import DEFAULTS, STAGES

FLAGS = {
    "max_size": ("decode",), "matcher": ("pose",), "masks_dir": ("mask",),
    "threshold": ("mask",), "max_flare": ("select",), "preset": ("finetune",),
    "iters": ("finetune",), "device": ("finetune", "mask", "render"), "path": ("render",),
    "frames": ("render",), "seconds": ("render",), "fps": ("render", "export"),
}
"""The one-shot's own flags: each sets the field of that name in these stages' configs (name,
default and help from the first one's dataclass); every other field: --set."""
HELP = {
    "path": "the video's camera path: interpolate, spiral or a camera-path FILE.json.",
    "fps": "frame rate (default 24 with CUDA; 12 on CPU, where rendering is slow).",
}


def _picks() -> list[Pick]:
    picks = []
    for name, stages in FLAGS.items():
        default = DEFAULTS.get(stages[0], {}).get(name, ...)
        picks.append(Pick(STAGES[stages[0]], name, help_prefix=", ".join(stages) + ": ",
                          help=HELP.get(name),
                          **({"default": None} if name == "fps" else
                             {} if default is ... else {"default": default})))
    return picks


def register(app: typer.Typer) -> None:
    @fields_command(app, "run", _picks())
    def run_cmd(
        photos: Path = typer.Argument(..., help="Folder of photos (raw or JPEG/PNG/TIFF) or "
                                      "videos, or a workspace to resume."),
        out: Path = typer.Option(None, "--out", "-o",
                                 help="Workspace folder (default: <photos>.deflare beside it)."),
        *,
        values,
        set_: list[str] = typer.Option(
            None, "--set", "-s", metavar="STAGE.FIELD=VALUE",
            help="Any other stage option, e.g. --set finetune.rays=512 --set export.crf=23 "
                 f"(stages: {' '.join(STAGES)}; fields: each stage command's --help)."),
        force: bool = typer.Option(False, "--force", help="Rerun every stage."),
    ) -> None:
        """Run every stage on a photo folder; resumes where a previous run stopped."""
        from workflows.oneshot import (
            OneShotConfig,
            _stage_configs,
            apply_overrides,
            default_fps,
            run_all,
        )

        if values["fps"] is None:
            values["fps"] = default_fps(values["device"])
        configs = _stage_configs()
        for name, stages in FLAGS.items():
            for stage in stages:
                configs[stage] = replace(configs[stage], **{name: values[name]})
        configs = apply_overrides(configs, list(set_ or []))
        run_all(OneShotConfig(photos=photos, out=out, stages=configs, force=force))
