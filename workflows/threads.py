"""The one thread policy of every entry point: idle OpenMP threads sleep, torch threads as asked.

On a shared 2-core machine PyTorch's OpenMP threads spin while they wait for each other; with
other processes on the cores a training step was 20-30x slower than with
``OMP_WAIT_POLICY=PASSIVE`` (docs/presets.md). The OpenMP runtime reads the variable once,
when torch loads, so ``apply_thread_policy()`` must run before the first ``import torch``:
the CLI (workflows/cli.py) calls it when it is imported, the research package
(workflows/research/__init__.py) when any of its modules is (``python -m
workflows.research.pretrain`` under torchrun included), and the scripts in benchmarks/ and
tests/conftest.py before they import torch. An environment that sets the variable wins.
(``gnfr/__init__.py`` sets the same default for library users who import gnfr first.)
"""

from __future__ import annotations

import os

WAIT_POLICY = "PASSIVE"


def apply_thread_policy(threads: int | None = None) -> None:
    """Set ``OMP_WAIT_POLICY=PASSIVE`` unless the environment already sets it (no effect once
    torch is loaded); with ``threads``, also ``torch.set_num_threads(threads)`` (this imports
    torch)."""
    os.environ.setdefault("OMP_WAIT_POLICY", WAIT_POLICY)
    if threads is not None:
        import torch

        torch.set_num_threads(threads)
