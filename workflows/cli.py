"""The ``deflare-scene`` command line (typer).

``deflare-scene ./photos`` (a folder as the first argument) runs the whole pipeline; the
subcommands run one stage each; the research tools (``RESEARCH_COMMANDS``) sit beside them.
Every command module in ``workflows/commands`` exposes ``register(app)``; heavy imports
(torch, pycolmap, rawpy) happen inside the commands, so ``--help`` is instant and the GPU
machine (no pycolmap) can run the neural stages.
"""

from __future__ import annotations

import errno
import importlib
import sys

import typer

from pipeline import interrupts
from pipeline.errors import UserError
from pipeline.interrupts import Terminated
from workflows.threads import apply_thread_policy

apply_thread_policy()  # when the CLI is imported, before any command loads torch

app = typer.Typer(
    name="deflare-scene",
    help="Flare-free renders and video of a scene from a folder of photos (GN-FR).\n\n"
    "Run everything: deflare-scene ./photos   (see `deflare-scene run --help` for options)",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode="rich",
)


@app.callback()
def _root() -> None:
    """Flare-free renders and video of a scene from a folder of photos (GN-FR)."""


# one module per command group, in the order the pipeline runs them
COMMAND_MODULES = [
    "run", "decode", "pose", "synth", "mask", "depth", "select", "finetune", "render", "export",
    "fmg", "pretrain", "eval", "eval_llff", "bench",
]
RESEARCH_COMMANDS = ("synth", "fmg", "pretrain", "eval", "eval_llff", "bench")
"""The research tools among them (their code: pipeline/synth.py, workflows/research/); the
others are the product: the one-shot and one command per stage."""
_registered = False
DISK_ERRORS = (errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EPERM)
"""Errors of the disk or its permissions: reported in one line (the run resumes once they
are fixed) instead of a traceback; any other OSError is a bug and keeps its traceback."""


def _register_all() -> None:
    global _registered
    if _registered:
        return
    for name in COMMAND_MODULES:  # every module exists: a missing one is a packaging bug
        importlib.import_module(f"workflows.commands.{name}").register(app)
    for info in app.registered_commands:  # `--help`'s list: each summary on one line
        if info.short_help is None and info.callback is not None and info.callback.__doc__:
            info.short_help = short_help(info.callback.__doc__)
    _registered = True


def short_help(doc: str) -> str:
    """The first paragraph of a command's docstring as one line (the docstring's own line
    breaks would otherwise break the command list of ``--help`` mid-sentence)."""
    return " ".join(doc.strip().split("\n\n")[0].split())


def command_names() -> set[str]:
    _register_all()
    cmd = typer.main.get_command(app)
    return set(getattr(cmd, "commands", {}))


def main(argv: list[str] | None = None) -> int:
    """Run the CLI on ``argv`` and return the exit status (tests call this directly)."""
    from gnfr.malloc import keep_freed_memory

    keep_freed_memory()  # DEFLARE_MALLOC=keep, before the stages' tensors (gnfr/malloc.py)
    argv = list(sys.argv[1:] if argv is None else argv)
    names = command_names()
    if argv and not argv[0].startswith("-") and argv[0] not in names:
        argv.insert(0, "run")  # `deflare-scene ./photos` is the one-shot command
    cmd = typer.main.get_command(app)
    try:
        cmd.main(args=argv, prog_name="deflare-scene", standalone_mode=True)
        code = 0
    except SystemExit as e:  # click's own exit: help, usage errors (status 2), aborts
        stop = _interruption(e)  # typer turns Ctrl-C into an exit with status 130
        code = (_stopped(stop) if stop is not None else
                e.code if isinstance(e.code, int) else (0 if e.code is None else 1))
    except UserError as e:
        typer.secho(f"error: {e}", fg="red", err=True)
        code = 2
    except KeyboardInterrupt as e:
        code = _stopped(e)
    except OSError as e:
        if e.errno not in DISK_ERRORS:
            raise
        where = f" ({e.filename})" if e.filename else ""
        typer.secho(f"error: {e.strerror}{where}: free disk space or fix the permissions (or "
                    "choose another --out), then rerun the same command to resume", fg="red",
                    err=True)
        code = 1
    return code


def _interruption(exc: BaseException) -> KeyboardInterrupt | None:
    """The KeyboardInterrupt (Ctrl-C, or SIGTERM's ``Terminated``) behind an exit, if any:
    typer re-raises one as an exit with status 130, click as a SystemExit of that."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return exc
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return None


def _stopped(e: KeyboardInterrupt) -> int:
    """One line saying how the run stopped and that it resumes; 143 for SIGTERM, else 130."""
    stop = "terminated (SIGTERM)" if isinstance(e, Terminated) else "interrupted"
    typer.secho(f"{stop}: rerun the same command to resume where it stopped", err=True)
    return 143 if isinstance(e, Terminated) else 130


def entry() -> None:
    """The ``deflare-scene`` console script: SIGTERM stops it like Ctrl-C
    (``pipeline.interrupts``)."""
    interrupts.install()
    sys.exit(main())


if __name__ == "__main__":
    entry()
