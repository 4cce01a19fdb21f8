"""Progress bars and console output shared by every stage (rich)."""

from __future__ import annotations

import contextlib
import os
import sys
import time
from collections.abc import Iterable, Iterator
from typing import TypeVar

from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)

console = Console(stderr=True, highlight=False, soft_wrap=True)  # one message, one line
T = TypeVar("T")


class _Progress(Progress):
    """rich Progress that, when stderr is not a terminal (logs, CI, nohup), prints a plain
    line per task at most every ``PLAIN_EVERY_S`` seconds and when the task completes. Its
    estimate of the time left is taken at the rate of the work done since the task was added,
    so a resumed run (a task added with ``completed`` > 0) is not credited with the steps of
    the run before it."""

    PLAIN_EVERY_S = 30.0

    def __init__(self, *args, plain: bool = False, **kwargs):
        super().__init__(*args, **kwargs)
        self._plain = plain
        self._last: dict = {}
        self._start: dict = {}  # task id -> completed when added

    def add_task(self, *args, **kwargs):
        task_id = super().add_task(*args, **kwargs)
        self._start[task_id] = self._tasks[task_id].completed
        return task_id

    def update(self, task_id, **kwargs) -> None:
        super().update(task_id, **kwargs)
        self._maybe_log(task_id)

    def advance(self, task_id, advance: float = 1) -> None:
        super().advance(task_id, advance)
        self._maybe_log(task_id)

    def _maybe_log(self, task_id) -> None:
        if not self._plain:
            return
        task = self._tasks[task_id]
        now = time.monotonic()
        done = task.total is not None and task.completed >= task.total
        last = self._last.setdefault(task_id, now)
        if (now - last >= self.PLAIN_EVERY_S or done) and self._last.get(("done", task_id)) is None:
            total = f"/{task.total:g}" if task.total is not None else ""
            extra = " ".join(f"{k}={v}" for k, v in task.fields.items() if v not in (None, ""))
            elapsed = task.elapsed or 0.0
            left = ""
            since = task.completed - self._start.get(task_id, 0)
            if not done and task.total is not None and since > 0:
                left = ", " + time_left(elapsed * (task.total - task.completed) / since)
            console.print(f"{task.description}: {task.completed:g}{total} "
                          f"({elapsed:.0f} s{left}) {extra}".rstrip())
            self._last[task_id] = now
            if done:
                self._last[("done", task_id)] = True


def time_left(seconds: float) -> str:
    """A plain progress line's estimate of the time left, at the rate so far: ``about 40 s
    left``, ``about 8.5 min left``, ``about 2.3 h left``."""
    if seconds < 90:
        return f"about {seconds:.0f} s left"
    if seconds < 90 * 60:
        return f"about {seconds / 60:.{1 if seconds < 600 else 0}f} min left"
    return f"about {seconds / 3600:.1f} h left"


def make_progress(*extra_columns, quiet: bool = False) -> Progress:
    """A rich progress bar on stderr; plain periodic lines when not a terminal; nothing
    shown when ``quiet``."""
    plain = not quiet and not sys.stderr.isatty()
    return _Progress(
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        *extra_columns,
        TimeElapsedColumn(),
        TimeRemainingColumn(),
        console=console,
        disable=plain or quiet,
        transient=False,
        plain=plain,
    )


def track(items: Iterable[T], description: str, total: int | None = None) -> Iterator[T]:
    """Iterate with a progress bar."""
    if total is None and hasattr(items, "__len__"):
        total = len(items)  # type: ignore[arg-type]
    with make_progress() as prog:
        task = prog.add_task(description, total=total)
        for item in items:
            yield item
            prog.advance(task)


def info(msg: str) -> None:
    console.print(msg)


def warn(msg: str) -> None:
    console.print(f"[yellow]warning:[/yellow] {msg}")


@contextlib.contextmanager
def quiet_stderr():
    """Silence C libraries' own messages on fd 2 (LibRaw, FFmpeg): the stage names bad files
    itself."""
    sys.stderr.flush()
    saved, devnull = os.dup(2), os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 2)
    try:
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.close(devnull)
