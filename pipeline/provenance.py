"""Where a number came from: the code (git commit, dirty or not), the machine, a file's hash.

Checkpoints (``pipeline/finetune.py``) and results files (``workflows/eval.py``) record these
so that a results file proves its own provenance instead of the code at reading time
describing it.
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import shlex
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def sha256(path: str | os.PathLike) -> str:
    """Hex sha256 of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _git(*args: str) -> str | None:
    """stdout of a git command in this checkout (unstripped), None when it fails."""
    try:
        out = subprocess.run(["git", "-C", str(REPO), *args], capture_output=True, text=True,
                             timeout=20, check=True)
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout


def code_version() -> dict:
    """{"commit", "dirty", "dirty_files", "diff_sha256"} of the checkout this package runs
    from (commit None when it is not a git checkout or git is absent). ``dirty_files``
    lists modified and untracked (not ignored) files: results written from a dirty tree do
    not match the commit exactly; ``diff_sha256`` (of ``git diff HEAD`` and the untracked
    files' contents) tells such trees apart."""
    from importlib import metadata

    try:
        version = metadata.version("deflare-scene")
    except metadata.PackageNotFoundError:
        version = None
    commit = (_git("rev-parse", "HEAD") or "").strip() or None
    status = _git("status", "--porcelain", "--untracked-files=all") if commit else None
    files = sorted(ln[3:] for ln in (status or "").splitlines() if ln.strip())
    digest = None
    if files:
        h = hashlib.sha256((_git("diff", "HEAD") or "").encode())
        for f in (f for f in files if (REPO / f).is_file()):
            if (_git("ls-files", "--", f) or "").strip() == "":  # untracked: its content
                h.update(f.encode() + b"\0" + (REPO / f).read_bytes())
        digest = h.hexdigest()
    return {"package_version": version, "commit": commit,
            "dirty": None if commit is None else bool(files), "dirty_files": files,
            "diff_sha256": digest}


def cpu_model() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return cpu


def machine() -> dict:
    """CPU model, cores, torch version and threads, OMP_NUM_THREADS, GPU (None without)."""
    import torch

    info = {"cpu": cpu_model(), "cores": os.cpu_count(), "torch_threads":
            torch.get_num_threads(), "omp_num_threads": os.environ.get("OMP_NUM_THREADS"),
            "torch": torch.__version__, "python": platform.python_version(),
            "platform": platform.platform(), "cuda": None}
    if torch.cuda.is_available():
        p = torch.cuda.get_device_properties(0)
        info["cuda"] = {"name": p.name, "memory_gib": round(p.total_memory / 2**30, 1),
                        "cuda": torch.version.cuda}
    return info


def device_name(device) -> str:
    """'cpu: <model>' or 'cuda: <GPU name>' for a torch device."""
    import torch

    if getattr(device, "type", str(device)).startswith("cuda") and torch.cuda.is_available():
        return f"cuda: {torch.cuda.get_device_name(device)}"
    return f"cpu: {cpu_model()}"


def command_line() -> str:
    """The command that is running, as typed (``deflare-scene ...`` for the CLI)."""
    argv = list(sys.argv)
    if argv and (Path(argv[0]).name == "deflare-scene"
                 or Path(argv[0]).as_posix().endswith("workflows/cli.py")):
        argv[0] = "deflare-scene"
    return shlex.join(argv)


def write_result(path: str | os.PathLike | None, record: dict) -> dict:
    """``record`` stamped with the code version, the machine and the command line, written
    as JSON to ``path`` (folders made; nothing written when ``path`` is None). Returns it."""
    record = {**record, "code": code_version(), "machine": machine(),
              "command": command_line()}
    if path is not None:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(record, indent=1, default=str) + "\n")
    return record
