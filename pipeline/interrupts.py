"""SIGTERM ends a run the way Ctrl-C does: a one-line message, exit status 143, resumable.

A `kill`, a `timeout` or a batch scheduler's stop (SLURM sends SIGTERM at the time limit)
reaches the process as SIGTERM. Python's default dies without a word, and once pycolmap is
imported glog's failure handler owns the signal and prints a native stack trace as if the
program had crashed. The command-line entry point (``workflows.cli.entry``) calls
``install``: SIGTERM then raises ``Terminated`` (a KeyboardInterrupt, so every stage's
clean-up and the CLI's "rerun to resume" path apply), and ``reclaim``, called right after
pycolmap is imported (``pipeline.colmap_io.import_pycolmap``), takes the signal back from
glog. Code used as a library (tests, notebooks) keeps whatever handler it had.
"""

from __future__ import annotations

import signal
import threading


class Terminated(KeyboardInterrupt):
    """The process received SIGTERM (raised by the handler ``install`` sets)."""


def _raise_terminated(signum, frame) -> None:
    raise Terminated()


def _main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


def install() -> None:
    """SIGTERM raises ``Terminated`` in the main thread from now on."""
    if _main_thread():
        signal.signal(signal.SIGTERM, _raise_terminated)


def reclaim() -> None:
    """Re-register ``install``'s handler with the OS if it was installed: a native library
    loaded since (glog, through pycolmap) may have replaced it behind Python's back."""
    if _main_thread() and signal.getsignal(signal.SIGTERM) is _raise_terminated:
        signal.signal(signal.SIGTERM, _raise_terminated)
