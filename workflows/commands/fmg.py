"""`deflare-scene fmg train|eval|calibrate|overlay`: the flare mask network (PSPNet)."""

from __future__ import annotations

from pathlib import Path

import typer

from workflows.config_cli import config_command

TRAIN_CONFIGS = "workflows.research.fmg_train"
"""The module of `fmg train`'s config dataclass."""
EVAL_CONFIGS = "workflows.research.fmg_eval"
"""The module of the config dataclasses of `fmg eval`, `fmg calibrate` and `fmg overlay`."""


def register(app: typer.Typer) -> None:
    fmg = typer.Typer(help="Train or evaluate the FMG flare-mask network.",
                      no_args_is_help=True)
    app.add_typer(fmg, name="fmg")

    @config_command(fmg, "train", f"{TRAIN_CONFIGS}:FMGTrainConfig", group="fmg",
                    exclude=("weight_decay", "seed"))
    def train_cmd(config) -> None:
        """Train the FMG on flare composited onto photos; held-out scenes are never seen."""
        from workflows.research.fmg_eval import format_metrics
        from workflows.research.fmg_train import train

        typer.echo(format_metrics(train(config)))

    @config_command(fmg, "eval", f"{EVAL_CONFIGS}:FMGEvalConfig", group="fmg")
    def eval_cmd(config) -> None:
        """mIoU / mAcc on held-out composites: default, unseen and night flare settings, or
        per kind of flare (--per-kind) beside leave-one-kind-out models (--loo); or the
        working-size sweep (--work-sizes), clean photos (--clean) or flare-free composites
        with hard negatives (--negatives)."""
        from pipeline.provenance import sha256, write_result
        from workflows.research.fmg_eval import run_eval

        metrics, table, weights = run_eval(config)
        typer.echo(table)
        if config.out:  # stamped with the code, the machine, the command and the weights' hash
            write_result(config.out, {**metrics, "weights_sha256": sha256(weights)})

    @config_command(fmg, "calibrate", f"{EVAL_CONFIGS}:FMGCalibrateConfig", group="fmg")
    def calibrate_cmd(config) -> None:
        """Pick the flare probability cut of highest flare IoU on development composites."""
        from pipeline.mask import DEFAULT_WEIGHTS, load_fmg_weights
        from pipeline.provenance import sha256, write_result
        from workflows.research.fmg_eval import calibrate, format_calibration, write_threshold

        weights = config.weights or DEFAULT_WEIGHTS
        load_fmg_weights(weights)  # a missing or foreign file: one clear line
        sweep = calibrate(weights, config.data, config.count, config.seed)
        typer.echo(format_calibration(sweep))
        if config.out:
            write_result(config.out, {**sweep, "weights_sha256": sha256(weights)})
        if config.write:
            write_threshold(weights, sweep["best"])
            typer.echo(f"wrote threshold={sweep['best']:g} into {weights}")

    @config_command(fmg, "overlay", f"{EVAL_CONFIGS}:FMGOverlayConfig", group="fmg")
    def overlay_cmd(
        config,
        photos: list[Path] = typer.Argument(..., help="Photos to mask (e.g. real flare)."),
    ) -> None:
        """One image: each photo beside each model's mask (red, outlined) at its cut."""
        from workflows.research.fmg_eval import run_overlay

        for key, fraction in run_overlay(config).items():
            typer.echo(f"{key}: {100 * fraction:.2f} % marked")
        typer.echo(f"wrote {config.out}" + (f" and {config.json}" if config.json else ""))
