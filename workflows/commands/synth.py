"""`deflare-scene synth WS --out DIR`: impose 3D-consistent synthetic flare on a clean scene."""

from __future__ import annotations

from pathlib import Path

import typer

from pipeline.errors import UserError


def parse_point(text: str | None) -> tuple[float, float, float] | None:
    """'X,Y,Z' -> (x, y, z); a clear error otherwise."""
    if text is None:
        return None
    try:
        xyz = tuple(float(v) for v in text.split(","))
    except ValueError:
        xyz = ()
    if len(xyz) != 3:
        raise UserError(f"--light {text!r} must be three numbers X,Y,Z (world frame of "
                        "cameras.json), e.g. --light 0.1,-0.2,0.5")
    return xyz  # type: ignore[return-value]


def register(app: typer.Typer) -> None:
    @app.command("synth")
    def synth_cmd(
        ws: Path = typer.Argument(..., help="Posed workspace of CLEAN photos (after `pose`)."),
        out: Path = typer.Option(..., "--out", "-o", help="Output folder for the flared scene."),
        seed: int = typer.Option(0, help="Seed of lens, light, intensities and flared views."),
        light: str = typer.Option(None, help="Light position X,Y,Z in the world frame "
                                  "(default: near the scene, visible in most views)."),
        heldout: int = typer.Option(None, help="Hold out N views, evenly spread."),
        heldout_every: int = typer.Option(None, help="Hold out every K-th view (default 8; "
                                          "0 = none)."),
        flare_prob: float = typer.Option(1.0, help="Fraction of views that get flare."),
        force: bool = typer.Option(False, "--force", help="Redo even if up to date."),
    ) -> None:
        """Impose one lens's flare from one 3D light on every view; keep clean ground truth.

        Writes DIR/photos (flared, held-out views left out), DIR/clean, DIR/masks_gt,
        DIR/cameras_gt.json, DIR/split.json and DIR/README.md.
        """
        from pipeline.synth import SynthConfig, run
        from pipeline.workspace import Workspace

        if heldout is not None and heldout_every is not None:
            raise UserError("give --heldout N or --heldout-every K, not both")
        cfg = SynthConfig(out=out, seed=seed, light=parse_point(light), heldout=heldout,
                          heldout_every=8 if heldout_every is None else heldout_every,
                          flare_prob=flare_prob)
        paths = run(cfg, Workspace.open(ws), force=force)
        typer.echo(f"wrote {len(paths)} outputs to {out}")
