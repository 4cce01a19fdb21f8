"""`deflare-scene eval SCENE`: PSNR / SSIM of GN-FR, its ablations and baselines."""

from __future__ import annotations

from pathlib import Path

import typer


def register(app: typer.Typer) -> None:
    @app.command("eval")
    def eval_cmd(
        scene: Path = typer.Argument(..., help="Folder written by `deflare-scene synth` (use a "
                                     "scene of TEST_SCENES: fern, kermit or cyprus)."),
        out: Path = typer.Option(None, "--out", "-o", help="Evaluation workspace "
                                 "(default SCENE/eval.ws); results in OUT/eval/."),
        variants: str = typer.Option("gnfr,gnt,no_ps,no_vs,no_ml,input,inpaint,photos",
                                     help="Comma-separated methods: gnfr, gnt (all GN-FR "
                                     "parts off), no_ps, no_vs, no_ml (single ablations), "
                                     "input (flared photo), inpaint (OpenCV Telea), photos "
                                     "(warped by depth, no network)."),
        masks: str = typer.Option("fmg", help="fmg (FMG network) | gt (SCENE/masks_gt)."),
        fmg_weights: Path = typer.Option(None, help="FMG weights (default: shipped)."),
        preset: str = typer.Option("auto", help="Training preset of every neural variant: "
                                   "auto (paper on CUDA, quick on CPU) | quick | paper | tiny "
                                   "(smoke tests only)."),
        iters: int = typer.Option(None, help="Override steps (same for every variant)."),
        rays: int = typer.Option(None, help="Override rays per step."),
        samples: int = typer.Option(None, help="Override samples per ray."),
        views: int = typer.Option(None, help="Override the number of source views."),
        init: str = typer.Option("auto", help="auto | scratch | FILE.safetensors."),
        render_scale: float = typer.Option(0.5, help="Held-out renders at this fraction of "
                                           "full size (smaller is faster)."),
        device: str = typer.Option("auto", help="auto | cpu | cuda."),
        seed: int = typer.Option(0, help="Training seed of every variant."),
        color_match: bool = typer.Option(True, "--color-match/--no-color-match",
                                         help="De-flared inputs with the fill's colour match "
                                         "(as the product writes them)."),
        fill: str = typer.Option("hybrid", "--fill", help="Render fill of the neural variants: "
                                 "hybrid (photos warped by depth where they agree, the "
                                 "network elsewhere) | network."),
        grid_rows: int = typer.Option(4, help="Views shown in grid.jpg."),
        force: bool = typer.Option(False, "--force", help="Redo every stage."),
    ) -> None:
        """Score GN-FR against vanilla GNT, single ablations, the flared input and
        inpainting on a synthetic-flare scene; writes table.md, results.json, grid.jpg.

        Every variant's finetune and renders are resumable stages: rerun the same command
        after an interruption.
        """
        from pipeline.errors import UserError
        from workflows.research.eval import EvalConfig, run
        from workflows.research.eval.config import parse_variants

        if preset not in ("auto", "paper", "quick", "tiny"):
            raise UserError(f"--preset {preset}: choose auto, paper, quick or tiny")
        cfg = EvalConfig(scene=scene, out=out, variants=parse_variants(variants), masks=masks,
                         fmg_weights=fmg_weights, preset=preset, iters=iters, rays=rays,
                         samples=samples, views=views, init=init, render_scale=render_scale,
                         device=device, seed=seed, grid_rows=grid_rows, force=force,
                         color_match=color_match, fill=fill)
        folder = run(cfg)
        typer.echo((folder / "table.md").read_text())
