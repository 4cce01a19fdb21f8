"""`deflare-scene render WS --path P`: de-flared photos and camera-path frames."""

from __future__ import annotations

from pathlib import Path

import typer

from workflows.config_cli import config_command


def register(app: typer.Typer) -> None:
    @config_command(app, "render", "pipeline.render.config:RenderConfig",
                    aliases={"path": ("-p",)})
    def render_cmd(
        config,
        workspace: Path = typer.Argument(..., help="Workspace folder."),
        force: bool = typer.Option(False, "--force", help="Rerender every frame."),
    ) -> None:
        """Render de-flared input photos (WS/deflared) or a camera path (WS/renders/<path>).

        Every source view is encoded once and shared by all frames; frames already written
        are skipped when the command is rerun. On CPU novel frames default to 1/4 of the
        input size; on CUDA to the full size.
        """
        from pipeline.render import run
        from pipeline.workspace import Workspace

        for p in run(config, Workspace.open(workspace), force=force):
            typer.echo(str(p))
