"""`deflare-scene export WS`: video, comparisons, scene.glb and nerfstudio transforms.json."""

from __future__ import annotations

from pathlib import Path

import typer


def register(app: typer.Typer) -> None:
    @app.command("export")
    def export_cmd(
        workspace: Path = typer.Argument(..., help="Workspace folder."),
        path: str = typer.Option("interpolate", "--path", "-p",
                                 help="Rendered path for the video (folder in WS/renders)."),
        fps: float = typer.Option(24.0, help="Video frame rate."),
        crf: int = typer.Option(18, min=0, max=51, help="H.264 quality: 0 lossless .. 51 "
                                "worst (18 visually lossless)."),
        compare: bool = typer.Option(True, help="Write <scene>_compare.mp4/.jpg "
                                     "(input | de-flared)."),
        glb: bool = typer.Option(True, help="Add the camera path to scene.glb."),
        transforms: bool = typer.Option(True, help="Write nerfstudio transforms.json and "
                                        "masks_nerfstudio/."),
        force: bool = typer.Option(False, "--force", help="Rewrite every output."),
    ) -> None:
        """Write WS/<scene>.mp4 (H.264), comparisons, scene.glb with the path and
        transforms.json (nerfstudio)."""
        from pipeline.export import ExportConfig, run
        from pipeline.workspace import Workspace

        cfg = ExportConfig(path=path, fps=fps, crf=crf, compare=compare, glb=glb,
                           transforms=transforms)
        for p in run(cfg, Workspace.open(workspace), force=force):
            typer.echo(str(p))
