"""`deflare-scene eval SCENE`: PSNR / SSIM of GN-FR, its ablations and baselines."""

from __future__ import annotations

from pathlib import Path

import typer

from workflows.config_cli import config_command


def register(app: typer.Typer) -> None:
    @config_command(app, "eval", "workflows.research.eval.config:EvalConfig",
                    aliases={"out": ("-o",)})
    def eval_cmd(
        config,
        scene: Path = typer.Argument(..., help="Folder written by `deflare-scene synth` (use a "
                                     "scene of TEST_SCENES: fern, kermit or cyprus)."),
        force: bool = typer.Option(False, "--force", help="Redo every stage."),
    ) -> None:
        """Score GN-FR against vanilla GNT, single ablations, the flared input and
        inpainting on a synthetic-flare scene; writes table.md, results.json, grid.jpg.

        Every variant's finetune and renders are resumable stages: rerun the same command
        after an interruption.
        """
        from workflows.research.eval import run

        folder = run(config)
        typer.echo((folder / "table.md").read_text())
