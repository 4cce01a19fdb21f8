"""`deflare-scene export WS`: video, comparisons, scene.glb and nerfstudio transforms.json."""

from __future__ import annotations

from pathlib import Path

import typer

from workflows.config_cli import config_command


def register(app: typer.Typer) -> None:
    @config_command(app, "export", "pipeline.export:ExportConfig", aliases={"path": ("-p",)})
    def export_cmd(
        config,
        workspace: Path = typer.Argument(..., help="Workspace folder."),
        force: bool = typer.Option(False, "--force", help="Rewrite every output."),
    ) -> None:
        """Write WS/<scene>.mp4 (H.264), comparisons, scene.glb with the path and
        transforms.json (nerfstudio)."""
        from pipeline.export import run
        from pipeline.workspace import Workspace

        for p in run(config, Workspace.open(workspace), force=force):
            typer.echo(str(p))
