"""`deflare-scene select WS`: which views may be training targets, ranked sources."""

from __future__ import annotations

from pathlib import Path

import typer


def register(app: typer.Typer) -> None:
    @app.command("select")
    def select_cmd(
        workspace: Path = typer.Argument(..., help="Workspace folder (after `mask`)."),
        max_flare: float = typer.Option(0.10, "--max-flare",
                                        help="Views with more flare than this fraction are "
                                        "never training targets."),
        force: bool = typer.Option(False, "--force", help="Rerun even if up to date."),
    ) -> None:
        """Write WS/views.json (View Sampler rules)."""
        from pipeline.select import SelectConfig, run
        from pipeline.workspace import Workspace

        run(SelectConfig(max_flare=max_flare), Workspace.open(workspace), force=force)
