"""`deflare-scene bench`: training it/s, render s/frame and peak memory, fast vs reference."""

from __future__ import annotations

from pathlib import Path

import typer


def register(app: typer.Typer) -> None:
    @app.command("bench")
    def bench_cmd(
        out: Path = typer.Option(Path("bench.json"), "--out", "-o", help="JSON file to write."),
        device: str = typer.Option("all", help="all (cpu, and cuda when present) | cpu | "
                                   "cuda."),
        preset: str = typer.Option("quick", help="Training preset measured (quick | paper | "
                                   "tiny)."),
        steps: int = typer.Option(10, help="Timed training steps per mode."),
        rays: int = typer.Option(None, help="Rays timed per rendered frame, scaled to the "
                                 "whole frame (default: whole frame on CUDA, 4096 on CPU)."),
        samples: int = typer.Option(None, help="Samples per ray when rendering (default: "
                                    "the preset's)."),
        chunk: int = typer.Option(None, help="Rays per forward pass when rendering "
                                  "[default: the render stage's, 1024 CUDA / 256 CPU]."),
        repeats: int = typer.Option(2, help="Render passes per path, alternating fast and "
                                    "reference; the fastest of each counts."),
        isolate: bool = typer.Option(True, "--isolate/--no-isolate",
                                     help="CPU: each measurement in a fresh process (peak "
                                     "memory per measurement)."),
        quick: bool = typer.Option(False, "--quick", help="Small fast run (2 steps, 128 "
                                   "rays, 8 samples, smaller training images, no isolation)."),
    ) -> None:
        """Measure speed and peak memory on a synthetic scene (no data needed), each beside
        the plain fp32 reference path measured in the same run."""
        from workflows.bench import BenchConfig, print_table, run

        devices = () if device == "all" else tuple(d.strip() for d in device.split(","))
        cfg = BenchConfig(out=out, devices=devices, preset=preset, steps=steps, rays=rays,
                          samples=samples, chunk=chunk, isolate=isolate, quick=quick,
                          repeats=repeats)
        record = run(cfg)
        print_table(record)
        typer.echo(f"wrote {out}")
