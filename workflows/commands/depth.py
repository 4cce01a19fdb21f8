"""`deflare-scene depth WS`: per-view depth and confidence by plane-sweep stereo."""

from __future__ import annotations

from pathlib import Path

import typer


def register(app: typer.Typer) -> None:
    @app.command("depth")
    def depth_cmd(
        workspace: Path = typer.Argument(..., help="Workspace folder (after `pose`; flare "
                                         "masks from `mask` are honoured when present)."),
        neighbours: int = typer.Option(4, "--neighbours", help="Nearest views matched "
                                       "against each view."),
        planes: int = typer.Option(48, "--planes", help="Depth hypotheses per view."),
        window: int = typer.Option(7, "--window", help="Matching window side (odd)."),
        keep: int = typer.Option(2, "--keep", help="Best-k neighbours a pixel's cost "
                                 "averages (robust to a flared or occluding neighbour)."),
        min_confidence: float = typer.Option(0.5, "--min-confidence",
                                             help="Depths less confident are dropped."),
        consistency: float = typer.Option(0.02, "--consistency",
                                          help="Relative depth agreement a neighbour must "
                                          "show (0: no check)."),
        force: bool = typer.Option(False, "--force", help="Rerun even if up to date."),
    ) -> None:
        """Write WS/depth/<stem>.npz (depth, confidence) for every view (docs/depth.md)."""
        from pipeline.depth import DepthConfig, run
        from pipeline.workspace import Workspace

        cfg = DepthConfig(neighbours=neighbours, planes=planes, window=window, keep=keep,
                          min_confidence=min_confidence, consistency=consistency)
        cfg.check()
        run(cfg, Workspace.open(workspace), force=force)
