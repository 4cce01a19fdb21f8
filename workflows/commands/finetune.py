"""`deflare-scene finetune WS`: fit GN-FR to a workspace -> WS/model/."""

from __future__ import annotations

from pathlib import Path

import typer

from workflows.config_cli import config_command


def register(app: typer.Typer) -> None:
    @config_command(app, "finetune", "pipeline.finetune:FinetuneConfig")
    def finetune_cmd(
        config,
        workspace: Path = typer.Argument(..., help="Workspace folder (after `pose`; `mask` "
                                         "and `select` give GN-FR its flare handling)."),
        force: bool = typer.Option(False, "--force", help="Retrain from the start."),
    ) -> None:
        """Fine-tune GN-FR on a workspace (resumes an interrupted run)."""
        from pipeline.finetune import run
        from pipeline.workspace import Workspace

        run(config, Workspace.open(workspace), force=force)
