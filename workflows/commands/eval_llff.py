"""`deflare-scene eval-llff SCENE`: novel-view PSNR / SSIM on an LLFF scene (LLFF protocol).

Every 8th view held out, with or without synthetic flare on the training views.
"""

from __future__ import annotations

from pathlib import Path

import typer

from workflows.config_cli import config_command


def register(app: typer.Typer) -> None:
    @config_command(app, "eval-llff", "workflows.research.eval_llff:LlffEvalConfig",
                    aliases={"out": ("-o",)})
    def eval_llff_cmd(
        config,
        scene: Path = typer.Argument(..., help="LLFF folder (poses_bounds.npy + images/ or "
                                     "images_<factor>/), e.g. ../shared/data/scenes/fern."),
        force: bool = typer.Option(False, "--force", help="Redo every stage."),
    ) -> None:
        """Fine-tune on an LLFF scene's training views and score its held-out views at full
        size (the field's standard protocol), beside published per-scene numbers.

        Every stage is resumable: rerun the same command after an interruption.
        """
        from workflows.research.eval_llff import run

        path = run(config)
        typer.echo((path.parent / "table.md").read_text())
