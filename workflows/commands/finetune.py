"""`deflare-scene finetune WS`: fit GN-FR to a workspace -> WS/model/."""

from __future__ import annotations

from pathlib import Path

import typer


def register(app: typer.Typer) -> None:
    @app.command("finetune")
    def finetune_cmd(
        workspace: Path = typer.Argument(..., help="Workspace folder (after `pose`; `mask` "
                                         "and `select` give GN-FR its flare handling)."),
        preset: str = typer.Option("auto", help="paper (GNT-sized, 50k steps) | quick (CPU "
                                   "sized: smaller model, sources at 1/4 resolution, 1500 "
                                   "steps) | auto (paper with CUDA, quick otherwise)."),
        iters: int = typer.Option(None, help="Override the preset's number of steps."),
        rays: int = typer.Option(None, help="Override rays per step."),
        samples: int = typer.Option(None, help="Override samples per ray."),
        views: int = typer.Option(None, help="Override the number of source views."),
        cached_features: bool = typer.Option(None, "--cached-features/--end-to-end",
                                             help="Frozen encoder, sources encoded once "
                                             "(default: end-to-end)."),
        device: str = typer.Option("auto", help="auto | cpu | cuda | mps."),
        init: str = typer.Option("auto", help="auto (shipped weights if they match) | "
                                 "scratch | path to a .safetensors checkpoint."),
        no_point_sampler: bool = typer.Option(False, "--no-point-sampler",
                                              help="Ablation: attend flared points too."),
        no_view_sampler: bool = typer.Option(False, "--no-view-sampler",
                                             help="Ablation: nearest sources regardless of "
                                             "flare; flared views may be targets."),
        no_mask_loss: bool = typer.Option(False, "--no-mask-loss",
                                          help="Ablation: loss over every pixel."),
        reference: bool = typer.Option(False, "--reference",
                                       help="Plain fp32 path (no bf16, no fused attention)."),
        seed: int = typer.Option(0, help="Random seed."),
        force: bool = typer.Option(False, "--force", help="Retrain from the start."),
    ) -> None:
        """Fine-tune GN-FR on a workspace (resumes an interrupted run)."""
        from pipeline.finetune import FinetuneConfig, run
        from pipeline.workspace import Workspace

        cfg = FinetuneConfig(preset=preset, iters=iters, rays=rays, samples=samples,
                             views=views, cached_features=cached_features, device=device,
                             point_sampler=not no_point_sampler,
                             view_sampler=not no_view_sampler, mask_loss=not no_mask_loss,
                             reference=reference, init=init, seed=seed)
        if preset not in ("auto", "paper", "quick"):
            from pipeline.errors import UserError
            raise UserError(f"--preset {preset}: choose paper, quick or auto")
        run(cfg, Workspace.open(workspace), force=force)
