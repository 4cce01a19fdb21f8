"""A training run's settings kept in its folder, so that resuming it under others is refused.

``pretrain`` and ``fmg train`` resume whenever their ``--out`` holds a checkpoint. Without a
record of what the run was started with, a rerun that changed what it trains on (other
scenes, a kind of flare left out or not, another preset) silently went on from a
checkpoint of the other settings, and the weights it wrote were labelled with the new ones.
``OUT/run_settings.json`` holds the settings a run was started with; a resume compares them
and stops with a one-line error naming the first option that differs. Options that may
change between attempts (more steps, the device, checkpoint spacing, the data's path on
another machine) are left out by each tool. A run started before this file existed resumes
as before and is recorded then.
"""

from __future__ import annotations

import json
from pathlib import Path

from pipeline.errors import UserError
from pipeline.workspace import atomic_write_json

SETTINGS_FILE = "run_settings.json"


def _plain(settings: dict) -> dict:
    """``settings`` as JSON reads them back (paths as text, tuples as lists)."""
    return json.loads(json.dumps(settings, default=str, sort_keys=True))


def _shown(value) -> str:
    if value in (None, [], ""):
        return "none"
    return ",".join(map(str, value)) if isinstance(value, list) else str(value)


def refuse_other_settings(out: Path, settings: dict, tool: str) -> None:
    """Raise a UserError if ``out`` records a start under settings other than ``settings``
    (an option's key ``snake_case`` is named as ``--snake-case``); nothing without a
    record."""
    path = Path(out) / SETTINGS_FILE
    if not path.is_file():
        return
    try:
        started = json.loads(path.read_text())
    except (OSError, ValueError) as e:
        raise UserError(f"{path} is unreadable ({e}): delete it to resume {out} as it is, "
                        "or give another --out") from None
    now = _plain(settings)
    for key in sorted(set(started) | set(now)):
        if started.get(key) != now.get(key):
            flag = "--" + key.replace("_", "-")
            raise UserError(f"{tool}: {out} was started with {flag} "
                            f"{_shown(started.get(key))} (now {_shown(now.get(key))}): resume "
                            f"it with the options it was started with, or give another --out")


def record_settings(out: Path, settings: dict) -> None:
    """Write ``settings`` as those ``out``'s run was started with."""
    atomic_write_json(Path(out) / SETTINGS_FILE, _plain(settings))
