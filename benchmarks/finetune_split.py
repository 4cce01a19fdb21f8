"""Benchmark of the fine-tune's processes on the CPU: each step shared by 1, 2, ... processes.

    python benchmarks/finetune_split.py --workspace WS [--workers 1,2] [--iters 300] \
        [--repeats 2] [--out docs/results/finetune_split_cpu.json]

The finetune stage trains ``--iters`` steps from the shipped weights (the stage's defaults
otherwise: ``quick`` on the CPU, one thread per process) once per ``--workers`` count, in a
scratch workspace sharing WS's earlier stages (hard links under the system temp folder: WS is
only read), the counts interleaved ``--repeats`` times; the fastest pass of each counts (on a
shared machine a pass measures the load of its moment as much as the setting). A pass's
speed is its steps over the stage's wall time (the helpers' start and the sources'
preparation included, as a user's fine-tune pays them) and the training loop's own it/s.
The trained weights and the metric lines of each count are compared with the first count's:
the same training but for the rounding of sums taken in another order, which training
compounds step by step as a different seed would (``max_weight_diff``, and the first metric
line's loss and psnr, where the runs have not yet drifted apart). Memory: the peak resident
size of this process (which holds the one-process runs too) and of the largest helper (each
child process's ``VmHWM`` read every half second while it runs: ``RUSAGE_CHILDREN`` would
count the parent's memory a spawned child held between its fork and its exec).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks.render_speed import parse_counts  # noqa: E402


class ChildPeak:
    """The largest ``VmHWM`` (peak resident memory, kB) of this process's children seen
    while it runs (a thread reading /proc every ``every`` seconds)."""

    def __init__(self, every: float = 0.5):
        import threading

        self.kb, self.every, self.stop = 0, every, threading.Event()
        self.thread = threading.Thread(target=self._poll, daemon=True)

    def _poll(self) -> None:
        import os

        me = os.getpid()
        while not self.stop.wait(self.every):
            try:
                kids = Path(f"/proc/{me}/task/{me}/children").read_text().split()
            except OSError:
                continue
            for pid in kids:
                try:
                    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
                        if line.startswith("VmHWM:"):
                            self.kb = max(self.kb, int(line.split()[1]))
                except OSError:
                    pass

    def __enter__(self) -> ChildPeak:
        self.thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self.stop.set()
        self.thread.join()


def weights_diff(a: Path, b: Path) -> float:
    """Largest absolute difference between two weight files' tensors."""
    from safetensors.torch import load_file

    x, y = load_file(str(a)), load_file(str(b))
    return max(float((x[k].float() - y[k].float()).abs().max()) for k in x)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workspace", type=Path, required=True,
                    help="A workspace through the select stage (and its depth maps).")
    ap.add_argument("--workers", default="1,2")
    ap.add_argument("--iters", type=int, default=300)
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    counts = parse_counts(a.workers, "--workers")
    if a.iters < 1 or a.repeats < 1:
        raise SystemExit("--iters and --repeats: give at least 1")
    from workflows.threads import apply_thread_policy

    apply_thread_policy()  # before torch loads (workflows/threads.py)
    import shutil

    import torch

    from pipeline import finetune
    from pipeline.errors import UserError
    from pipeline.provenance import write_result
    from pipeline.workspace import Workspace
    from workflows.research.eval.workspaces import shared_workspace

    try:
        base = Workspace.open(a.workspace)
        base.require("select")
    except UserError as e:
        raise SystemExit(str(e)) from None
    cores = torch.get_num_threads()
    best = {w: math.inf for w in counts}
    passes: dict[int, list[dict]] = {w: [] for w in counts}
    compare: dict[int, dict] = {}
    with (tempfile.TemporaryDirectory(prefix="deflare-finetune-split-") as tmp,
          ChildPeak() as helpers):
        ws = shared_workspace(base, Path(tmp) / "ws")
        keep = Path(tmp) / "first"
        for rep in range(a.repeats):
            for w in counts:
                cfg = finetune.FinetuneConfig(iters=a.iters, workers=w, device="cpu")
                t0 = time.perf_counter()
                finetune.run(cfg, ws, force=True)
                wall = time.perf_counter() - t0
                loop = ws.stage_record("finetune")["it_per_s"]
                passes[w].append({"steps_per_s": a.iters / wall, "loop_it_per_s": loop,
                                  "wall_s": round(wall, 2)})
                best[w] = min(best[w], wall)
                print(f"pass {rep + 1}, workers {w}: {a.iters / wall:.2f} steps/s "
                      f"({wall:.1f} s; loop {loop:.2f} it/s)", flush=True)
                if rep == 0:
                    # the weights every run started from (path, sha256), as the model says
                    init = (finetune.checkpoint_provenance(ws.model_file) or {}).get("init")
                    lines = [json.loads(x) for x in ws.metrics_jsonl.read_text().splitlines()]
                    if w == counts[0]:
                        shutil.copytree(ws.model, keep)
                    first = [json.loads(x) for x in
                             (keep / ws.metrics_jsonl.name).read_text().splitlines()]
                    compare[w] = {
                        "max_weight_diff": weights_diff(keep / ws.model_file.name,
                                                        ws.model_file),
                        "first_line": {k: lines[0][k] for k in ("step", "loss", "psnr")},
                        "first_line_of_first_count": {k: first[0][k]
                                                      for k in ("step", "loss", "psnr")}}
    import resource

    rec = {"workspace": str(base.root), "iters": a.iters, "repeats": a.repeats,
           "cores_torch_would_use": cores,
           "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
           "helper_peak_rss_mb": helpers.kb / 1024,
           "rows": [{"workers": w, "steps_per_s": a.iters / best[w], "wall_s": best[w],
                     "speedup": best[counts[0]] / best[w], "passes": passes[w], **compare[w]}
                    for w in counts],
           "compared_with": {"workers": counts[0]},
           "init": init}
    for row in rec["rows"]:
        print(f"workers {row['workers']}: {row['steps_per_s']:.2f} steps/s (fastest of "
              f"{a.repeats}), {row['speedup']:.2f}x; weights differ from workers "
              f"{counts[0]}'s by at most {row['max_weight_diff']:.2e}")
    print(f"peak memory: {rec['peak_rss_mb']:.0f} MB here, {rec['helper_peak_rss_mb']:.0f} MB "
          "the largest helper")
    write_result(a.out, rec)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
