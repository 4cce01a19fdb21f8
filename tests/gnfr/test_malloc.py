"""gnfr.malloc.keep_freed_memory (``DEFLARE_MALLOC=keep``, an opt-in): glibc's malloc keeps
freed blocks instead of handing them back to the kernel, so re-allocating them faults no pages
in; without the variable malloc is left as it is.
Each arm runs in a fresh interpreter (the settings last a process's life)."""

from __future__ import annotations

import os
import platform
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]

CHURN = """
import resource, sys
import numpy as np
from gnfr.malloc import keep_freed_memory
applied = keep_freed_memory()
rng = np.random.default_rng(0)
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(60):  # blocks of 1-24 MiB made and freed, as a frame's tensors are
    held = [np.ones(int(n), np.uint8) for n in rng.integers(1 << 20, 24 << 20, 6)]
    del held
print(int(applied), resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""


def _churn(malloc_env: str | None) -> tuple[bool, int]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("MALLOC_")}
    env.pop("DEFLARE_MALLOC", None)
    if malloc_env is not None:
        env["DEFLARE_MALLOC"] = malloc_env
    env["PYTHONPATH"] = str(REPO)
    out = subprocess.run([sys.executable, "-c", CHURN], env=env, capture_output=True,
                         text=True, check=True).stdout.split()
    return out[0] == "1", int(out[1])


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's mallopt: Linux only")
def test_freed_blocks_are_reused_without_page_faults():
    applied, faults = _churn("keep")
    off_applied, off_faults = _churn(None)
    if not applied:
        assert platform.libc_ver()[0] != "glibc"
        pytest.skip("this C library has no glibc mallopt (musl?): nothing to keep")
    assert not off_applied
    # 60 rounds of six 1-24 MiB blocks: without the settings most rounds fault their pages
    # in again (85 000 faults here), with them the heap's blocks are reused (about 6 000)
    assert faults < 0.25 * off_faults, (faults, off_faults)


def test_settings_are_applied_once_and_reported(monkeypatch):
    """Off unless ``DEFLARE_MALLOC=keep``; the answer is remembered for the process."""
    from gnfr import malloc

    monkeypatch.setattr(malloc, "_applied", None)
    monkeypatch.delenv("DEFLARE_MALLOC", raising=False)
    assert malloc.keep_freed_memory() is False
    monkeypatch.setenv("DEFLARE_MALLOC", "keep")
    assert malloc.keep_freed_memory() is False  # remembered: set at the process's start
    monkeypatch.setattr(malloc, "_applied", None)
    monkeypatch.setattr(malloc.sys, "platform", "darwin")  # another C library: left alone
    assert malloc.keep_freed_memory() is False
