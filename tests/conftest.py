"""Shared fixtures: where the real test data lives, and skips when it is absent."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from workflows.threads import apply_thread_policy

apply_thread_policy()  # before torch loads (workflows/threads.py)

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = Path(os.environ.get("DEFLARE_SHARED_DATA", REPO.parent / "shared" / "data"))


def load_benchmark(name: str):
    """The module of benchmarks/<name>.py (the folder is not a package)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(name, REPO / "benchmarks" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def shared(*parts: str) -> Path:
    """Path into ../shared/data; skips the test with a clear reason if it is absent."""
    p = SHARED_DATA.joinpath(*parts)
    if not p.exists():
        pytest.skip(f"real test data {p} is absent (set DEFLARE_SHARED_DATA to the shared/data "
                    "folder to run this test)")
    return p


@pytest.fixture(autouse=True)
def _few_threads(monkeypatch):
    """Keep torch to the 2 cores CI has and make CPU runs reproducible; the render renders
    in the test's process unless a test asks for workers (``pipeline.render.workers.
    AUTO_WORKERS``: the tests' counters and simulated interrupts patch this process); the
    stages run fp32 unless a test asks for bf16 (``DEFLARE_CPU_BF16=0``, which the
    benchmarks' and CLI's child processes inherit: whether the default is bf16 depends on
    the CPU, and the suite must mean the same on every machine)."""
    try:
        import torch
    except ImportError:  # pragma: no cover
        return
    torch.set_num_threads(min(2, os.cpu_count() or 1))
    monkeypatch.setattr("pipeline.render.workers.AUTO_WORKERS", False)
    monkeypatch.setattr("pipeline.finetune.AUTO_WORKERS", False)
    monkeypatch.setenv("DEFLARE_CPU_BF16", "0")


@pytest.fixture
def one_torch_thread():
    """One torch thread for the test (modules opt in with ``pytestmark =
    pytest.mark.usefixtures("one_torch_thread")``): training-heavy tests on a shared 2-core
    machine run far slower with oversubscribed threads."""
    import torch

    n = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(n)


def pytest_addoption(parser):
    parser.addoption("--run-slow", action="store_true", default=False,
                     help="also run tests marked slow")


def pytest_collection_modifyitems(config, items):
    if not config.getoption("--run-slow"):
        skip_slow = pytest.mark.skip(reason="slow: run with --run-slow")
        for item in items:
            if "slow" in item.keywords:
                item.add_marker(skip_slow)
    try:
        import torch
        has_cuda = torch.cuda.is_available()
    except ImportError:  # pragma: no cover
        has_cuda = False
    skip_gpu = pytest.mark.skip(reason="needs a CUDA GPU")
    for item in items:
        if "gpu" in item.keywords and not has_cuda:
            item.add_marker(skip_gpu)


def fake_fmg_probs(monkeypatch, fn) -> None:
    """Replace the mask stage's network with ``fn(model, images, work_size, scales=(1.0,),
    pads=())`` -> a list of [H, W] maps: ``pipeline.mask.fmg_probs``, and
    ``fmg_probs_pair`` (``network_maps`` calls it for `--pads-keep regions`) as ``fn``
    without and with the pads."""
    from pipeline import mask as M

    monkeypatch.setattr(M, "fmg_probs", fn)
    monkeypatch.setattr(M, "fmg_probs_pair", lambda model, images, work_size, scales, pads: (
        fn(model, images, work_size, scales, ()), fn(model, images, work_size, scales, pads)))
