"""`deflare-scene synth WS --out DIR`: impose 3D-consistent synthetic flare on a clean scene."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import typer

from pipeline.errors import UserError
from workflows.config_cli import config_command


def register(app: typer.Typer) -> None:
    @config_command(app, "synth", "pipeline.synth:SynthConfig", aliases={"out": ("-o",)})
    def synth_cmd(
        config,
        ctx: typer.Context,
        ws: Path = typer.Argument(..., help="Posed workspace of CLEAN photos (after `pose`)."),
        kinds: str = typer.Option(None, help="Kinds of flare the lens may combine, "
                                  "comma-separated: starburst,ghosts,streaks,glare,scatter "
                                  "(default: all; see docs/flare_kinds.md)."),
        force: bool = typer.Option(False, "--force", help="Redo even if up to date."),
    ) -> None:
        """Impose one lens's flare from one 3D light on every view; keep clean ground truth.

        Writes DIR/photos (flared, held-out views left out), DIR/clean, DIR/masks_gt,
        DIR/cameras_gt.json, DIR/split.json and DIR/README.md.
        """
        from pipeline.flare import FlareConfig, parse_kinds
        from pipeline.synth import run
        from pipeline.workspace import Workspace

        if config.heldout is not None and \
                ctx.get_parameter_source("heldout_every").name != "DEFAULT":
            raise UserError("give --heldout N or --heldout-every K, not both")
        if kinds is not None:
            config = replace(config, flare=FlareConfig(kinds=parse_kinds(kinds)))
        paths = run(config, Workspace.open(ws), force=force)
        typer.echo(f"wrote {len(paths)} outputs to {config.out}")
