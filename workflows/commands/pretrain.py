"""`deflare-scene pretrain SCENES...`: generalizable GN-FR across scenes (torchrun-ready)."""

from __future__ import annotations

from pathlib import Path

import typer

from workflows.config_cli import config_command


def register(app: typer.Typer) -> None:
    @config_command(app, "pretrain", "workflows.research.pretrain:PretrainConfig",
                    aliases={"out": ("-o",)})
    def pretrain_cmd(
        config,
        scenes: list[Path] = typer.Argument(..., help="Workspaces, LLFF folders "
                                            "(poses_bounds.npy), COLMAP workspaces (sparse/ + "
                                            "images/), or folders of them."),
    ) -> None:
        """Pretrain GN-FR across scenes.

        Several GPUs: torchrun --nproc_per_node K -m workflows.research.pretrain SCENES...
        """
        from workflows.research.pretrain import run

        run(config)
