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
        skip_width: int = typer.Option(0, help="Channels of the fine decoder (stride 4, "
                                       "then input size; 0: none)."),
        lr: float = typer.Option(2e-3, help="Peak learning rate."),
        ckpt_every: int = typer.Option(100, help="Steps between checkpoints."),
        eval_every: int = typer.Option(500, help="Steps between validation scores."),
        val_count: int = typer.Option(32, help="Held-out composites scored during training "
                                      "(twice as many at the end)."),
        night_prob: float = typer.Option(0.0, help="Probability of a night-darkened "
                                         "training background."),
        without: str = typer.Option("", help="Kinds of flare to leave out of training "
                                    "(comma-separated, of starburst,ghosts,streaks,glare,"
                                    "scatter): a leave-one-kind-out model."),
        init: Path = typer.Option(None, help="FMG weights to start from (same widths, "
                                  "depths and head width) when OUT has no checkpoint."),
        device: str = typer.Option("auto", help="auto, cpu or cuda."),
    ) -> None:
        """Train the FMG on flare composited onto photos; held-out scenes are never seen."""
        from pipeline.flare import parse_kinds
        from workflows.research.fmg_train import FMGTrainConfig, default_data, format_metrics, train

        cfg = FMGTrainConfig(out=out, data=data or default_data(), iters=iters, batch=batch,
                             size=size, widths=_ints(widths), depths=_ints(depths),
                             head_width=head_width, skip_width=skip_width, lr=lr,
                             ckpt_every=ckpt_every,
                             eval_every=eval_every, val_count=val_count, device=device,
                             night_prob=night_prob, init=init,
                             without=parse_kinds(without, "--without") if without else ())
        typer.echo(format_metrics(train(cfg)))

    @fmg.command("eval")
    def eval_cmd(
        weights: Path = WEIGHTS,
        data: Path = DATA,
        count: int = typer.Option(64, help="Held-out composites per flare setting (per kind "
                                  "with --per-kind)."),
        size: int = typer.Option(256, help="Composite side in pixels."),
        refine: bool = typer.Option(False, "--refine/--no-refine",
                                    help="Also score guided-filter refined masks."),
        per_kind: bool = typer.Option(False, "--per-kind/--no-per-kind", help="Score each "
                                      "kind of flare alone (leave-one-kind-out table)."),
        loo: list[Path] = typer.Option(None, "--loo", help="With --per-kind: weights trained "
                                       "with `fmg train --without KIND`, scored on that kind "
                                       "(repeat for several)."),
        work_sizes: str = typer.Option("", help="Instead: flare IoU of thin streaks and "
                                       "starbursts on held-out photos against the working "
                                       "size, e.g. 384,512,768."),
        clean: bool = typer.Option(False, "--clean/--no-clean", help="Instead: share of "
                                   "pixels marked on the clean photos of the test scenes."),
        work_size: int = typer.Option(512, help="With --clean: the network's working size "
                                      "(long side), as the mask stage's --work-size."),
        out: Path = typer.Option(None, "--out", help="Write the metrics here (JSON)."),
    ) -> None:
        """mIoU / mAcc on held-out composites: default, unseen and night flare settings, or
        per kind of flare (--per-kind) beside leave-one-kind-out models (--loo); or the
        working-size sweep (--work-sizes) or clean photos (--clean)."""
        from pipeline.mask import DEFAULT_WEIGHTS, load_fmg_weights
        from pipeline.workspace import atomic_write_json
        from workflows.research import fmg_train as ft
        from workflows.research.fmg_train import (
            default_data,
            evaluate,
            evaluate_kinds,
            format_kinds,
            format_metrics,
        )

        if loo and not per_kind:
            raise typer.BadParameter("--loo needs --per-kind", param_hint="--loo")
        if sum((per_kind, bool(work_sizes), clean)) > 1:
            raise typer.BadParameter("give one of --per-kind, --work-sizes, --clean")
        path = weights or DEFAULT_WEIGHTS
        for w in (path, *(loo or ())):
            load_fmg_weights(w)  # a missing or foreign file: one clear line
        if work_sizes:
            m = ft.work_size_sweep(path, data or default_data(), _ints(work_sizes))
            typer.echo(ft.format_work_sizes(m))
        elif clean:
            m = ft.clean_fractions(path, data or default_data(), work_size)
            typer.echo(ft.format_clean(m))
        elif per_kind:
            m = evaluate_kinds(path, data or default_data(), tuple(loo or ()), count,
                               size=size)
            typer.echo(format_kinds(m))
        else:
            m = evaluate(path, data or default_data(), count, refine=refine, size=size)
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
        from workflows.research.fmg_train import (
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

    @fmg.command("overlay")
    def overlay_cmd(
        photos: list[Path] = typer.Argument(..., help="Photos to mask (e.g. real flare)."),
        weights: list[Path] = typer.Option(None, "--weights", help="FMG weights, one column "
                                           "each (default: the shipped ones)."),
        out: Path = typer.Option(..., "--out", help="The overview JPEG to write."),
        work_size: int = typer.Option(512, help="The network's working size (long side)."),
    ) -> None:
        """One image: each photo beside each model's mask (red, outlined) at its cut."""
        from pipeline.mask import DEFAULT_WEIGHTS, load_fmg_weights
        from workflows.research.fmg_train import real_flare_overview

        ws = tuple(weights or (DEFAULT_WEIGHTS,))
        for w in ws:
            load_fmg_weights(w)
        for k, v in real_flare_overview(ws, tuple(photos), out, work_size).items():
            typer.echo(f"{k}: {100 * v:.2f} % marked")
        typer.echo(f"wrote {out}")
