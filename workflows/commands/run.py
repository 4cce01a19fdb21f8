"""`deflare-scene run PHOTOS` (also `deflare-scene PHOTOS`): the whole pipeline."""

from __future__ import annotations

from pathlib import Path

import typer


def register(app: typer.Typer) -> None:
    @app.command("run")
    def run_cmd(
        photos: Path = typer.Argument(..., help="Folder of photos (raw or JPEG/PNG/TIFF)."),
        out: Path = typer.Option(None, "--out", "-o",
                                 help="Workspace folder (default: <photos>.deflare beside it)."),
        max_size: int = typer.Option(1008, help="Decode: long side of decoded images."),
        matcher: str = typer.Option("auto", help="Pose: exhaustive, sequential or auto."),
        force: bool = typer.Option(False, "--force", help="Rerun every stage."),
    ) -> None:
        """Run every stage on a photo folder; resumes where a previous run stopped."""
        from workflows.oneshot import OneShotConfig, run_all

        run_all(OneShotConfig(photos=photos, out=out, max_size=max_size, matcher=matcher,
                              force=force))
