"""An opt-in (``DEFLARE_MALLOC=keep``): glibc's malloc keeps freed memory between tensors.

Torch on the CPU allocates a tensor's memory with malloc and frees it when the tensor goes.
glibc hands a large block to the kernel as it is freed (blocks over its mmap threshold are
unmapped; the heap's free top is trimmed past its trim threshold), so the next tensor of the
same size faults its pages in again, each zeroed by the kernel. :func:`keep_freed_memory`
raises the thresholds with ``mallopt``: blocks up to 32 MiB come from the heap and the heap
keeps up to 1 GiB of free top.

Judged in the ninety-seventh session (docs/performance.md, "Freed memory kept by malloc"):
the sample's frames rendered in fresh processes 0.830 times as long, but the README's main
job only 0.973 times as long (15:34.7 against 16:00.7) with its peak memory 1.24 times as
high (1.40 GB against 1.13), against a rule that allowed 1.10. So it is not the default:
``DEFLARE_MALLOC=keep`` turns it on (a long render on a machine with memory to spare), in the
CLI's process, the render workers and the fine-tune helpers alike. Other C libraries (macOS,
musl) are left alone.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import sys

M_TRIM_THRESHOLD, M_TOP_PAD, M_MMAP_THRESHOLD = -1, -2, -3
"""``mallopt`` parameters (glibc's malloc.h)."""
SETTINGS = ((M_MMAP_THRESHOLD, 32 << 20), (M_TRIM_THRESHOLD, 1 << 30), (M_TOP_PAD, 64 << 20))
"""(parameter, value): blocks up to 32 MiB from the heap (glibc's largest allowed), up to
1 GiB of the heap's free top kept, 64 MiB more asked of the kernel each time it grows."""
ENV = "DEFLARE_MALLOC"
"""``keep`` applies :data:`SETTINGS`; anything else leaves glibc's malloc as it is."""

_applied: bool | None = None


def keep_freed_memory() -> bool:
    """Apply :data:`SETTINGS` to this process's malloc once where ``DEFLARE_MALLOC=keep``;
    returns whether they are in force (False without it, off Linux, or where the C library
    has no glibc ``mallopt`` or refuses a value)."""
    global _applied
    if _applied is not None:
        return _applied
    _applied = False
    if os.environ.get(ENV, "").lower() != "keep" or not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):  # not glibc (musl has no mallopt)
        return False
    mallopt.argtypes, mallopt.restype = (ctypes.c_int, ctypes.c_int), ctypes.c_int
    _applied = all(mallopt(param, value) == 1 for param, value in SETTINGS)
    return _applied
