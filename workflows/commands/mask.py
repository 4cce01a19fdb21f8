"""`deflare-scene mask WS`: flare-occupancy masks (FMG or hand-made) for every view."""

from __future__ import annotations

from pathlib import Path

import typer

from workflows.config_cli import config_command


def register(app: typer.Typer) -> None:
    @config_command(app, "mask", "pipeline.mask:MaskConfig")
    def mask_cmd(
        config,
        workspace: Path = typer.Argument(..., help="Workspace folder (after `pose`)."),
        force: bool = typer.Option(False, "--force", help="Rerun even if up to date."),
    ) -> None:
        """Write WS/masks/, WS/flare.json and WS/masks_overview.jpg."""
        from pipeline.mask import run
        from pipeline.workspace import Workspace

        run(config, Workspace.open(workspace), force=force)
