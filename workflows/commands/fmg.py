"""`deflare-scene fmg train|eval|calibrate`: the flare mask network (PSPNet)."""

from __future__ import annotations

from pathlib import Path

import typer


def _ints(text: str) -> tuple[int, ...]:
    return tuple(int(v) for v in text.split(","))


# options shared by eval and calibrate (typer reads the same OptionInfo in both signatures)
WEIGHTS = typer.Option(None, "--weights", help="FMG weights (default: the shipped ones).")
DATA = typer.Option(None, help="Folder with backgrounds/ and scenes/.")


def register(app: typer.Typer) -> None:
    fmg = typer.Typer(help="Train or evaluate the FMG flare-mask network.",
                      no_args_is_help=True)
    app.add_typer(fmg, name="fmg")

    @fmg.command("train")
    def train_cmd(
        out: Path = typer.Option(..., "--out", help="Run folder (resumes if it has a "
                                 "checkpoint); the result is OUT/fmg.safetensors."),
        data: Path = typer.Option(None, help="Folder with backgrounds/ and scenes/ "
                                  "(default $DEFLARE_SHARED_DATA or ../shared/data)."),
        iters: int = typer.Option(3000, help="Optimizer steps."),
        batch: int = typer.Option(8, help="Composites per step."),
        size: int = typer.Option(256, help="Composite side in pixels."),
        widths: str = typer.Option("32,64,128,256", help="Backbone widths "
                                   "(ResNet-18: 64,128,256,512)."),
        depths: str = typer.Option("2,2,2,2", help="Blocks per stage (ResNet-34: 3,4,6,3)."),
        head_width: int = typer.Option(128, help="Head channels."),
        lr: float = typer.Option(2e-3, help="Peak learning rate."),
        ckpt_every: int = typer.Option(100, help="Steps between checkpoints."),
        eval_every: int = typer.Option(500, help="Steps between validation scores."),
        val_count: int = typer.Option(32, help="Held-out composites scored during training "
                                      "(twice as many at the end)."),
        night_prob: float = typer.Option(0.0, help="Probability of a night-darkened "
                                         "training background."),
        streak_prob: float = typer.Option(0.0, help="Probability of long streaks through "
                                          "the light on a flared training composite."),
        device: str = typer.Option("auto", help="auto, cpu or cuda."),
    ) -> None:
        """Train the FMG on flare composited onto photos; held-out scenes are never seen."""
        from workflows.fmg_train import FMGTrainConfig, default_data, format_metrics, train

        cfg = FMGTrainConfig(out=out, data=data or default_data(), iters=iters, batch=batch,
                             size=size, widths=_ints(widths), depths=_ints(depths),
                             head_width=head_width, lr=lr, ckpt_every=ckpt_every,
                             eval_every=eval_every, val_count=val_count, device=device,
                             night_prob=night_prob, streak_prob=streak_prob)
        typer.echo(format_metrics(train(cfg)))

    @fmg.command("eval")
    def eval_cmd(
        weights: Path = WEIGHTS,
        data: Path = DATA,
        count: int = typer.Option(64, help="Held-out composites per flare setting."),
        size: int = typer.Option(256, help="Composite side in pixels."),
        refine: bool = typer.Option(False, "--refine/--no-refine",
                                    help="Also score guided-filter refined masks."),
        out: Path = typer.Option(None, "--out", help="Write the metrics here (JSON)."),
    ) -> None:
        """mIoU / mAcc on held-out composites, default and unseen flare settings."""
        from pipeline.mask import DEFAULT_WEIGHTS
        from pipeline.workspace import atomic_write_json
        from workflows.fmg_train import default_data, evaluate, format_metrics

        m = evaluate(weights or DEFAULT_WEIGHTS, data or default_data(), count, refine=refine,
                     size=size)
        typer.echo(format_metrics(m))
        if out:
            atomic_write_json(out, m)

    @fmg.command("calibrate")
    def calibrate_cmd(
        weights: Path = WEIGHTS,
        data: Path = DATA,
        count: int = typer.Option(96, help="Training-side composites to score."),
        seed: int = typer.Option(7, help="Seed of the composites."),
        write: bool = typer.Option(False, "--write/--no-write", help="Store the best cut "
                                   "in the weights' metadata (the mask stage's default)."),
        out: Path = typer.Option(None, "--out", help="Write the sweep here (JSON)."),
    ) -> None:
        """Pick the flare probability cut of highest flare IoU on training-side composites."""
        from pipeline.mask import DEFAULT_WEIGHTS, load_fmg_weights
        from pipeline.workspace import atomic_write_json
        from workflows.fmg_train import (
            calibrate,
            default_data,
            format_calibration,
            write_threshold,
        )

        path = weights or DEFAULT_WEIGHTS
        load_fmg_weights(path)  # a missing or foreign file: one clear line
        res = calibrate(path, data or default_data(), count, seed)
        typer.echo(format_calibration(res))
        if out:
            atomic_write_json(out, res)
        if write:
            write_threshold(path, res["best"])
            typer.echo(f"wrote threshold={res['best']:g} into {path}")
