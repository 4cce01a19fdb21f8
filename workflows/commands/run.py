"""`deflare-scene run PHOTOS` (also plain `deflare-scene PHOTOS`): the whole pipeline."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import typer


def register(app: typer.Typer) -> None:
    @app.command("run")
    def run_cmd(
        photos: Path = typer.Argument(..., help="Folder of photos (raw or JPEG/PNG/TIFF)."),
        out: Path = typer.Option(None, "--out", "-o",
                                 help="Workspace folder (default: <photos>.deflare beside it)."),
        max_size: int = typer.Option(1008, help="decode: long side of decoded images."),
        matcher: str = typer.Option("auto", help="pose: exhaustive, sequential or auto."),
        masks: Path = typer.Option(None, help="mask: hand-made masks (one per stem) "
                                              "instead of the FMG network."),
        threshold: float = typer.Option(
            None, help="mask: flare probability cut (default: the cut calibrated for the "
            "FMG weights, 0.65 for the shipped ones)."),
        max_flare: float = typer.Option(0.10, help="select: views above this flare "
                                                   "fraction are never training targets."),
        preset: str = typer.Option("auto", help="finetune: paper, quick, or auto "
                                                "(paper with CUDA, quick otherwise)."),
        iters: int = typer.Option(None, help="finetune: training steps (default: preset)."),
        device: str = typer.Option("auto", help="finetune/render/mask: auto, cpu, cuda, mps."),
        path: str = typer.Option("interpolate", help="render: video path: interpolate, "
                                                     "spiral or a camera-path FILE.json."),
        frames: int = typer.Option(None, help="render: frames of the video path."),
        seconds: float = typer.Option(4.0, help="render: length of the video path."),
        fps: float = typer.Option(None, help="render/export: frame rate (default 24 with "
                                             "CUDA; 12 on CPU, where rendering is slow)."),
        set_: list[str] = typer.Option(
            None, "--set", "-s", metavar="STAGE.FIELD=VALUE",
            help="Any other stage option, e.g. --set finetune.rays=512 --set export.crf=23 "
                 "(stages: decode pose mask select finetune render export)."),
        force: bool = typer.Option(False, "--force", help="Rerun every stage."),
    ) -> None:
        """Run every stage on a photo folder; resumes where a previous run stopped."""
        from workflows.oneshot import (
            OneShotConfig,
            _stage_configs,
            apply_overrides,
            default_fps,
            run_all,
        )

        fps = fps or default_fps(device)
        st = _stage_configs()
        st["decode"] = replace(st["decode"], max_size=max_size)
        st["pose"] = replace(st["pose"], matcher=matcher)
        st["mask"] = replace(st["mask"], masks_dir=masks, threshold=threshold, device=device)
        st["select"] = replace(st["select"], max_flare=max_flare)
        st["finetune"] = replace(st["finetune"], preset=preset, iters=iters, device=device)
        st["render"] = replace(st["render"], path=path, frames=frames, seconds=seconds, fps=fps,
                               device=device)
        st["export"] = replace(st["export"], fps=fps)
        st = apply_overrides(st, list(set_ or []))
        run_all(OneShotConfig(photos=photos, out=out, stages=st, force=force))
