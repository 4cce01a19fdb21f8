"""`deflare-scene depth WS`: per-view depth and confidence by plane-sweep stereo."""

from __future__ import annotations

from pathlib import Path

import typer

from workflows.config_cli import config_command


def register(app: typer.Typer) -> None:
    @config_command(app, "depth", "pipeline.depth:DepthConfig")
    def depth_cmd(
        config,
        workspace: Path = typer.Argument(..., help="Workspace folder (after `pose`; flare "
                                         "masks from `mask` are honoured when present)."),
        force: bool = typer.Option(False, "--force", help="Rerun even if up to date."),
    ) -> None:
        """Write WS/depth/<stem>.npz (depth, confidence) for every view (docs/depth.md)."""
        from pipeline.depth import run
        from pipeline.workspace import Workspace

        run(config, Workspace.open(workspace), force=force)
