"""`deflare-scene pretrain SCENES...`: generalizable GN-FR across scenes (torchrun-ready)."""

from __future__ import annotations

from pathlib import Path

import typer


def register(app: typer.Typer) -> None:
    @app.command("pretrain")
    def pretrain_cmd(
        scenes: list[Path] = typer.Argument(..., help="Workspaces, LLFF folders "
                                            "(poses_bounds.npy), COLMAP workspaces (sparse/ + "
                                            "images/), or folders of them."),
        out: Path = typer.Option(Path("gnfr_pretrain"), "--out", "-o",
                                 help="Output folder (resumes when it holds a run)."),
        preset: str = typer.Option("pretrain", help="pretrain | pretrain-quick | tiny."),
        iters: int = typer.Option(None, help="Override the preset's number of steps."),
        flare: bool = typer.Option(True, "--flare/--no-flare",
                                   help="Impose synthetic flare with ground-truth masks."),
        flare_prob: float = typer.Option(0.5, help="Fraction of views given flare."),
        max_size: int = typer.Option(504, help="Long side scenes are loaded at."),
        device: str = typer.Option("auto", help="auto | cpu | cuda."),
        init: str = typer.Option("scratch", help="scratch | auto | a .safetensors path."),
        seed: int = typer.Option(0, help="Random seed."),
    ) -> None:
        """Pretrain GN-FR; several GPUs: torchrun --nproc_per_node K -m workflows.pretrain."""
        from gnfr.train import PRESETS
        from pipeline.errors import UserError
        from workflows.pretrain import PretrainConfig, run

        if preset not in PRESETS:
            raise UserError(f"--preset {preset}: choose one of {', '.join(PRESETS)}")
        run(PretrainConfig(scenes=list(scenes), out=out, preset=preset, iters=iters,
                           flare=flare, flare_prob=flare_prob, max_size=max_size,
                           device=device, seed=seed, init=init))
