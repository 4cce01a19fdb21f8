"""`deflare-scene mask WS`: flare-occupancy masks (FMG or hand-made) for every view."""

from __future__ import annotations

from pathlib import Path

import typer


def register(app: typer.Typer) -> None:
    @app.command("mask")
    def mask_cmd(
        workspace: Path = typer.Argument(..., help="Workspace folder (after `pose`)."),
        masks: Path = typer.Option(None, "--masks", help="Folder of hand-made masks, one "
                                   "image per view stem, nonzero = flare (replaces the FMG)."),
        threshold: float = typer.Option(
            None, help="Flare probability cut (default: the cut calibrated for the "
            "FMG weights, 0.65 for the shipped ones)."),
        weights: Path = typer.Option(None, "--weights",
                                     help="FMG weights (default: the shipped ones)."),
        work_size: int = typer.Option(512, help="Long side at which the FMG runs."),
        refine: bool = typer.Option(False, "--refine/--no-refine",
                                    help="Guided-filter the probabilities along image edges."),
        device: str = typer.Option("auto", help="auto, cpu or cuda."),
        force: bool = typer.Option(False, "--force", help="Rerun even if up to date."),
    ) -> None:
        """Write WS/masks/, WS/flare.json and WS/masks_overview.jpg."""
        from pipeline.mask import MaskConfig, run
        from pipeline.workspace import Workspace

        cfg = MaskConfig(weights=weights, masks_dir=masks, threshold=threshold,
                         work_size=work_size, refine=refine, device=device)
        run(cfg, Workspace.open(workspace), force=force)
