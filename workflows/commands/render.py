"""`deflare-scene render WS --path P`: de-flared photos and camera-path frames."""

from __future__ import annotations

from pathlib import Path

import typer

from pipeline.errors import UserError


def parse_size(text: str | None) -> tuple[int, int] | None:
    """'640x360' -> (640, 360); a UserError for anything else."""
    if not text:
        return None
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise UserError(f"--size {text!r}: write it as WIDTHxHEIGHT, e.g. 640x360") from None
    if w < 1 or h < 1:
        raise UserError(f"--size {text!r}: width and height must be positive")
    return w, h


def register(app: typer.Typer) -> None:
    @app.command("render")
    def render_cmd(
        workspace: Path = typer.Argument(..., help="Workspace folder."),
        path: str = typer.Option("inputs", "--path", "-p",
                                 help="inputs | interpolate | spiral | FILE.json "
                                 "(docs/camera_paths.md)."),
        frames: int = typer.Option(None, help="Frames of interpolate / spiral "
                                   "(default: --seconds x --fps)."),
        seconds: float = typer.Option(4.0, help="Length of interpolate / spiral."),
        fps: float = typer.Option(24.0, help="Frame rate used to count frames."),
        size: str = typer.Option(None, help="Novel frame size WIDTHxHEIGHT (overrides "
                                 "--scale)."),
        scale: float = typer.Option(None, help="Novel frames at this fraction of the input "
                                    "size [default: 0.25 on CPU, 1 on CUDA]."),
        chunk: int = typer.Option(None, help="Rays per forward pass [default: 1024 on CUDA, "
                                  "256 on CPU]."),
        device: str = typer.Option("auto", help="auto | cuda | cpu."),
        samples: int = typer.Option(None, help="Samples per ray [default: as trained]."),
        blend: str = typer.Option("mask", help="inputs: mask (replace only the flare region) "
                                  "| none (full render)."),
        color_match: bool = typer.Option(True, "--color-match/--no-color-match",
                                         help="inputs: match the fill's colours to the photo "
                                         "on the ring just outside the flare mask."),
        full_res: bool = typer.Option(False, "--full-res", help="inputs: also de-flare the "
                                      "original photos at full resolution (WS/deflared_full)."),
        checkpoint: Path = typer.Option(None, help="Weights [default: latest in WS/model]."),
        force: bool = typer.Option(False, "--force", help="Rerender every frame."),
    ) -> None:
        """Render de-flared input photos (WS/deflared) or a camera path (WS/renders/<path>).

        Every source view is encoded once and shared by all frames; frames already written
        are skipped when the command is rerun. On CPU novel frames default to 1/4 of the
        input size; on CUDA to the full size.
        """
        from pipeline.render import RenderConfig, run
        from pipeline.workspace import Workspace

        cfg = RenderConfig(path=path, frames=frames, seconds=seconds, fps=fps,
                           size=parse_size(size), scale=scale, chunk=chunk, device=device,
                           samples=samples, blend=blend, full_res=full_res, color_match=color_match,
                           checkpoint=str(checkpoint) if checkpoint else None)
        outs = run(cfg, Workspace.open(workspace), force=force)
        for p in outs:
            typer.echo(str(p))
