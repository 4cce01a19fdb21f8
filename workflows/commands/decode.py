"""`deflare-scene decode PHOTOS --out WS`: photos -> WS/decoded (+ WS/linear for raw)."""

from __future__ import annotations

from pathlib import Path

import typer


def register(app: typer.Typer) -> None:
    @app.command("decode")
    def decode_cmd(
        photos: Path = typer.Argument(..., help="Folder of photos (camera raw or JPEG/PNG/TIFF);"
                                      " only read, never written."),
        out: Path = typer.Option(None, "--out", "-o",
                                 help="Workspace folder (default: <photos>.deflare beside it)."),
        max_size: int = typer.Option(1008, "--max-size",
                                     help="Long side of the decoded images in pixels "
                                          "(never upscaled; 0 keeps the full size)."),
        force: bool = typer.Option(False, "--force", help="Decode again even if up to date."),
    ) -> None:
        """Decode raw/JPEG photos into WS/decoded (8-bit sRGB) and WS/linear (raw only)."""
        from pipeline import decode

        decode.run(decode.DecodeConfig(max_size=max_size), photos, out, force=force)
