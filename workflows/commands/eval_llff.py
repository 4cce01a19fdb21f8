"""`deflare-scene eval-llff SCENE`: novel-view PSNR / SSIM on an LLFF scene (every 8th view
held out), with or without synthetic flare on the training views."""

from __future__ import annotations

from pathlib import Path

import typer


def register(app: typer.Typer) -> None:
    @app.command("eval-llff")
    def eval_llff_cmd(
        scene: Path = typer.Argument(..., help="LLFF folder (poses_bounds.npy + images/ or "
                                     "images_<factor>/), e.g. ../shared/data/scenes/fern."),
        out: Path = typer.Option(None, "--out", "-o", help="Output folder (default "
                                 "./<scene>.llff_eval); results in OUT/results.json, "
                                 "OUT/table.md."),
        every: int = typer.Option(8, help="Hold out every K-th view (LLFF protocol: 8)."),
        max_size: int = typer.Option(504, help="Long side of the images (LLFF: 504)."),
        preset: str = typer.Option("auto", help="auto (paper on CUDA, quick on CPU) | quick | "
                                   "paper | tiny (smoke tests only)."),
        iters: int = typer.Option(None, help="Override the preset's steps."),
        rays: int = typer.Option(None, help="Override rays per step."),
        samples: int = typer.Option(None, help="Override samples per ray."),
        views: int = typer.Option(None, help="Override the number of source views."),
        init: str = typer.Option("auto", help="auto | scratch | FILE.safetensors."),
        device: str = typer.Option("auto", help="auto | cpu | cuda."),
        seed: int = typer.Option(0, help="Training seed."),
        fill: str = typer.Option("hybrid,network", "--fill", help="Render fills of the "
                                 "held-out views, comma-separated: hybrid, network; the "
                                 "flare protocol uses the first."),
        flare: bool = typer.Option(False, "--flare/--no-flare", help="Also impose synthetic "
                                   "flare on the training views and compare GN-FR with "
                                   "vanilla GNT (true masks)."),
        variants: str = typer.Option("gnfr,gnt,input", help="Methods of the flare protocol "
                                     "(as `eval --variants`)."),
        flare_seed: int = typer.Option(0, help="Seed of the synthetic flare."),
        force: bool = typer.Option(False, "--force", help="Redo every stage."),
    ) -> None:
        """Fine-tune on an LLFF scene's training views and score its held-out views at full
        size (the field's standard protocol), beside published per-scene numbers.

        Every stage is resumable: rerun the same command after an interruption.
        """
        from pipeline.errors import UserError
        from workflows.research.eval.config import parse_variants
        from workflows.research.eval_llff import LlffEvalConfig, run

        if preset not in ("auto", "paper", "quick", "tiny"):
            raise UserError(f"--preset {preset}: choose auto, paper, quick or tiny")
        cfg = LlffEvalConfig(
            scene=scene, out=out, every=every, max_size=max_size, preset=preset, iters=iters,
            rays=rays, samples=samples, views=views, init=init, device=device, seed=seed,
            fills=tuple(f.strip() for f in fill.split(",") if f.strip()), flare=flare,
            variants=parse_variants(variants), flare_seed=flare_seed, force=force)
        path = run(cfg)
        typer.echo((path.parent / "table.md").read_text())
