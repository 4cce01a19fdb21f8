"""Where a fine-tune step's time goes, part by part, with its views padded or stretched.

    python benchmarks/step_parts.py WS [--steps 60] [--rounds 2] [--out JSON]

Loads the workspace WS as the fine-tune does (``pipeline.training_scenes.load_workspace``)
twice: views of another size padded (the default, ``FinetuneConfig.pad_views``) and
stretched. For each, with the `quick` preset as the sample's fine-tune runs it (full-size
colours, CPU bf16 for the rays) and the encoder in fp32 and under CPU bf16
(``TrainConfig.encoder_bf16``), it times one-process steps on one thread, split as the
two-process step splits them (``gnfr.ray_split.part_step``): the encoder's forward, the rays'
forward to the loss, their backward to the features, and the encoder's backward. The
settings take turns for ``--rounds`` rounds, so the machine's drift falls on each alike;
the first 5 steps of each run are not timed. Reports the mean milliseconds a step of each
part (docs/performance.md, "Padded views in the fine-tune: the sample's cost"). Timings
only; the model is freshly initialised and not updated.
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import torch  # noqa: E402

PARTS = ("encoder_forward", "rays_forward", "rays_backward", "encoder_backward")
WARMUP = 5


def time_steps(ws: Path, pad: bool, encoder_bf16: bool, steps: int) -> dict:
    """Mean milliseconds a step of each of ``PARTS`` (and their total) over ``steps``
    one-process steps after ``WARMUP``, and the source bank's and encoder input's sizes."""
    from gnfr.model import GNFR
    from gnfr.train import PRESETS, compute_loss, prepare_sources, sample_batch
    from pipeline.training_scenes import load_workspace

    cfg = replace(PRESETS["quick"], full_res_colour=True, cpu_bf16=True,
                  encoder_bf16=encoder_bf16)
    scene = load_workspace(ws, pad=pad)
    torch.manual_seed(0)
    model = GNFR(cfg.model)
    bank, _ = prepare_sources(model, scene, cfg, "cpu")
    gen = torch.Generator().manual_seed(0)
    total = dict.fromkeys(PARTS, 0.0)
    for i in range(WARMUP + steps):
        batch = sample_batch(scene, cfg, gen)
        ids = batch.sources
        t0 = time.perf_counter()
        own = bank.encode(model, "cpu", ids, grad=True).feats
        t1 = time.perf_counter()
        leaf = own.detach().clone().requires_grad_()
        loss, _ = compute_loss(model, batch, bank.views(ids, leaf, "cpu"),
                               torch.arange(len(ids)), cfg)
        t2 = time.perf_counter()
        loss.backward()
        t3 = time.perf_counter()
        own.backward(leaf.grad)
        t4 = time.perf_counter()
        model.zero_grad(set_to_none=True)
        if i >= WARMUP:
            for k, dt in zip(PARTS, (t1 - t0, t2 - t1, t3 - t2, t4 - t3), strict=True):
                total[k] += dt
    ms = {k: 1000 * v / steps for k, v in total.items()}
    return {**ms, "total": sum(ms.values()), "bank": list(bank.images.shape),
            "encoder_input": list(bank.enc_images.shape)}


def mean_runs(runs: list[dict]) -> dict:
    """Each part's mean over the runs of one setting."""
    return {k: sum(r[k] for r in runs) / len(runs) for k in (*PARTS, "total")}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("ws", type=Path)
    ap.add_argument("--steps", type=int, default=60)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--out", type=Path)
    a = ap.parse_args(argv)
    if not (a.ws / "manifest.json").is_file():
        raise SystemExit(f"{a.ws}: not a workspace (no manifest.json)")
    from pipeline.provenance import write_result

    torch.set_num_threads(1)
    settings = [(pad, enc) for enc in (False, True) for pad in (True, False)]
    runs: dict[str, list[dict]] = {}
    for r in range(a.rounds):
        for pad, enc in settings:
            name = f"{'padded' if pad else 'stretched'}_{'encoder_bf16' if enc else 'fp32_encoder'}"
            rec = time_steps(a.ws, pad, enc, a.steps)
            runs.setdefault(name, []).append(rec)
            print(name, r, {k: round(v, 1) for k, v in rec.items() if k in (*PARTS, "total")},
                  flush=True)
    res = {"ws": str(a.ws), "steps": a.steps, "rounds": a.rounds, "threads": 1, "runs": runs,
           "mean_ms": {n: mean_runs(v) for n, v in runs.items()}}
    write_result(a.out, res)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
