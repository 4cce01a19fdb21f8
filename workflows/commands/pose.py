"""`deflare-scene pose WS`: pycolmap SfM -> WS/colmap, WS/images, WS/cameras.json."""

from __future__ import annotations

from pathlib import Path

import typer

from workflows.config_cli import config_command


def register(app: typer.Typer) -> None:
    @config_command(app, "pose", "pipeline.pose:PoseConfig")
    def pose_cmd(
        config,
        workspace: Path = typer.Argument(..., help="Workspace folder made by `decode`."),
        force: bool = typer.Option(False, "--force", help="Solve again even if up to date."),
    ) -> None:
        """Pose the decoded photos with COLMAP (pycolmap), undistort, write cameras.json."""
        from pipeline import pose
        from pipeline.workspace import Workspace

        pose.run(config, Workspace.open(workspace), force=force)
