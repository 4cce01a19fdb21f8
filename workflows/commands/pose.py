"""`deflare-scene pose WS`: pycolmap SfM -> WS/colmap, WS/images, WS/cameras.json."""

from __future__ import annotations

from pathlib import Path

import typer


def register(app: typer.Typer) -> None:
    @app.command("pose")
    def pose_cmd(
        workspace: Path = typer.Argument(..., help="Workspace folder made by `decode`."),
        matcher: str = typer.Option("auto", "--matcher",
                                    help="exhaustive, sequential, or auto (exhaustive for "
                                         "small sets, sequential for large or video-like)."),
        colmap_model: Path = typer.Option(None, "--colmap-model",
                                          help="Import this COLMAP sparse model instead of "
                                               "solving (images matched by file name)."),
        camera_model: str = typer.Option("SIMPLE_RADIAL", "--camera-model",
                                         help="COLMAP camera model (OPENCV for wide angle)."),
        threads: int = typer.Option(-1, "--threads", help="CPU threads for COLMAP (-1: all)."),
        colmap_log: bool = typer.Option(False, "--colmap-log", help="Show COLMAP's own log."),
        force: bool = typer.Option(False, "--force", help="Solve again even if up to date."),
    ) -> None:
        """Pose the decoded photos with COLMAP (pycolmap), undistort, write cameras.json."""
        from pipeline import pose
        from pipeline.workspace import Workspace

        ws = Workspace.open(workspace)
        cfg = pose.PoseConfig(matcher=matcher, colmap_model=str(colmap_model)
                              if colmap_model else None, camera_model=camera_model,
                              num_threads=threads, colmap_log=colmap_log)
        pose.run(cfg, ws, force=force)
