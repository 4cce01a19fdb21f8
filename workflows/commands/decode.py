"""`deflare-scene decode PHOTOS --out WS`: photos -> WS/decoded (+ WS/linear for raw)."""

from __future__ import annotations

from pathlib import Path

import typer

from workflows.config_cli import config_command


def register(app: typer.Typer) -> None:
    @config_command(app, "decode", "pipeline.decode:DecodeConfig")
    def decode_cmd(
        photos: Path = typer.Argument(..., help="Folder of photos (camera raw or JPEG/PNG/TIFF) or "
                                      "videos; only read, never written."),
        out: Path = typer.Option(None, "--out", "-o",
                                 help="Workspace folder (default: <photos>.deflare beside it)."),
        *,
        config,
        force: bool = typer.Option(False, "--force", help="Decode again even if up to date."),
    ) -> None:
        """Decode raw/JPEG photos and video frames into WS/decoded (8-bit sRGB), WS/linear (raw)."""
        from pipeline import decode

        decode.run(config, photos, out, force=force)
