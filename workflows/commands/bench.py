"""`deflare-scene bench`: training it/s, render s/frame and peak memory, fast vs reference."""

from __future__ import annotations

from dataclasses import replace

import typer

from workflows.config_cli import config_command


def register(app: typer.Typer) -> None:
    @config_command(app, "bench", "workflows.research.bench:BenchConfig", exclude=("devices",),
                    aliases={"out": ("-o",)})
    def bench_cmd(
        config,
        device: str = typer.Option("all", help="all (cpu, and cuda when present) | cpu | "
                                   "cuda, or a comma-separated list."),
    ) -> None:
        """Measure speed and peak memory on a synthetic scene (no data needed), each beside
        the plain fp32 reference path measured in the same run."""
        from workflows.research.bench import print_table, run

        devices = () if device == "all" else tuple(d.strip() for d in device.split(","))
        record = run(replace(config, devices=devices))
        print_table(record)
        typer.echo(f"wrote {config.out}")
