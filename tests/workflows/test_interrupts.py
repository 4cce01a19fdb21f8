"""SIGTERM (kill, timeout, a scheduler's stop) ends a run like Ctrl-C (pipeline/interrupts.py)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from pipeline.interrupts import Terminated
from workflows.cli import main

REPO = Path(__file__).resolve().parents[2]

SCRIPT = """
import os, signal, time
from pipeline import interrupts, colmap_io
interrupts.install()
{load}
try:
    os.kill(os.getpid(), signal.SIGTERM)
    time.sleep(10)
    print("not stopped")
except interrupts.Terminated:
    print("terminated")
"""


def _run(load: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", SCRIPT.format(load=load)], cwd=REPO,
                          capture_output=True, text=True, timeout=120)


def test_sigterm_after_pycolmap_is_an_interruption_not_a_native_crash():
    """Once the CLI's handler is installed, SIGTERM raises Terminated even after pycolmap
    (whose glog failure handler grabs SIGTERM at import) was loaded the project's way; a
    bare import shows what the project's way prevents: glog's stack trace and a kill."""
    pytest.importorskip("pycolmap")
    ok = _run("colmap_io.import_pycolmap()")
    assert ok.returncode == 0 and ok.stdout.strip() == "terminated", ok.stderr[-2000:]
    assert "stack trace" not in ok.stderr
    bare = _run("import pycolmap")
    assert bare.returncode != 0 and "terminated" not in bare.stdout
    assert "SIGTERM" in bare.stderr


def test_cli_reports_sigterm_as_resumable_with_status_143(tmp_path, monkeypatch, capsys):
    """The CLI turns Terminated into one line and exit status 143 (128 + 15), Ctrl-C into
    130; nothing else is printed (no traceback)."""
    import pipeline.decode

    for exc, code, word in ((Terminated, 143, "terminated (SIGTERM)"),
                            (KeyboardInterrupt, 130, "interrupted")):
        def stop(*a, exc=exc, **k):
            raise exc()

        monkeypatch.setattr(pipeline.decode, "run", stop)
        assert main(["decode", str(tmp_path)]) == code
        err = capsys.readouterr().err
        assert err.strip() == f"{word}: rerun the same command to resume where it stopped"


def test_disk_errors_are_one_line_others_keep_their_traceback(tmp_path, monkeypatch, capsys):
    """A full disk or a write refused mid-run: one line naming the file and what to do,
    status 1; an OSError that is not about the disk is a bug and is raised."""
    import errno
    import os

    import pipeline.decode

    def full(*a, **k):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(tmp_path / "x.png"))

    monkeypatch.setattr(pipeline.decode, "run", full)
    assert main(["decode", str(tmp_path)]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: No space left on device") and "x.png" in err
    assert err.endswith("rerun the same command to resume") and "\n" not in err

    def other(*a, **k):
        raise OSError(errno.EBADF, "Bad file descriptor")

    monkeypatch.setattr(pipeline.decode, "run", other)
    with pytest.raises(OSError, match="Bad file descriptor"):
        main(["decode", str(tmp_path)])


def test_an_output_folder_that_cannot_be_created_is_one_line(tmp_path, capsys):
    """`--out` somewhere no folder can be made (under a file): the workspace says so."""
    (tmp_path / "photos").mkdir()
    for i in range(3):
        (tmp_path / "photos" / f"{i}.jpg").write_bytes(b"")
    (tmp_path / "afile").write_text("x")
    assert main(["decode", str(tmp_path / "photos"), "--out", str(tmp_path / "afile" / "ws")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: cannot create the output folder") and "--out" in err
