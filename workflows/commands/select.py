"""`deflare-scene select WS`: which views may be training targets, ranked sources."""

from __future__ import annotations

from pathlib import Path

import typer

from workflows.config_cli import config_command


def register(app: typer.Typer) -> None:
    @config_command(app, "select", "pipeline.select:SelectConfig")
    def select_cmd(
        config,
        workspace: Path = typer.Argument(..., help="Workspace folder (after `mask`)."),
        force: bool = typer.Option(False, "--force", help="Rerun even if up to date."),
    ) -> None:
        """Write WS/views.json (View Sampler rules)."""
        from pipeline.select import run
        from pipeline.workspace import Workspace

        run(config, Workspace.open(workspace), force=force)
