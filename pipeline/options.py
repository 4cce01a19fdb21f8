"""Ranges of config fields declared once beside the field, their one check, one device resolver.

A config dataclass declares a field's range with ``option`` instead of a bare default:

    max_flare: float = option(0.10, ge=0, le=1)
    '''Views whose flare fraction is above this are never training targets.'''

``validate(cfg)`` checks every field against its declaration and raises a one-line
``UserError`` naming the command-line option, the value and what is allowed
(``--max-flare 5: must be between 0 and 1``). Every stage's ``run()`` calls it before it writes
anything; the CLI (``workflows/config_cli.py``) builds each command's options from the same
fields and docstrings, and ``--set STAGE.FIELD=VALUE`` goes through ``coerce`` and
``check_field`` here, so a range, a default or a help line is written in one place.

Rules (keyword arguments of ``option``, all optional; the default and ``flag``, ``sep`` and
``metavar`` are literals, as the CLI reads them from the source without importing the stage):
  ge, gt, le, lt   bounds of a number (or of each number of a tuple); a string names another
                   field of the config: ``le="neighbours"``
  choices          the allowed strings;  suffix: with ``choices``, also any path ending so
  odd              an odd integer;       device: auto | cpu | cuda | cuda:N, present here
  exists           a path (other than one of ``choices``) must name an existing file
  flag             the option's name when it is not ``--field-name``
  sep, metavar     how a tuple is written on the command line (``640x360``: sep "x")
A field left at None (an optional field not given) passes; a float must always be finite.
"""

from __future__ import annotations

import dataclasses
import math
import re
import shlex
import types
import typing
from pathlib import Path
from typing import Any

from pipeline.errors import UserError

RULES = ("flag", "ge", "gt", "le", "lt", "choices", "suffix", "odd", "device", "sep",
         "metavar", "exists")
DEVICES = "auto, cpu, cuda or cuda:N"


def option(default: Any = dataclasses.MISSING, *, default_factory: Any = dataclasses.MISSING,
           **rules: Any) -> Any:
    """A dataclass ``field`` whose metadata holds the rules above (checked by ``validate``)."""
    unknown = sorted(set(rules) - set(RULES))
    if unknown:
        raise TypeError(f"option(): unknown rule(s) {', '.join(unknown)}; known: "
                        f"{', '.join(RULES)}")
    return dataclasses.field(default=default, default_factory=default_factory,
                             metadata=rules)


def flag_of(f: dataclasses.Field) -> str:
    """The command-line option of a field: its ``flag`` rule, else ``--field-name``."""
    return f.metadata.get("flag") or "--" + f.name.replace("_", "-")


def show(value: Any, sep: str = ",") -> str:
    """A value as a user would type it on the command line."""
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, tuple):
        return sep.join(show(v) for v in value)
    if isinstance(value, str | Path):
        return shlex.quote(str(value))
    return str(value)


# --------------------------------------------------------------------------- devices
def resolve_device(name: str, flag: str = "--device") -> str:
    """The torch device for ``name``: auto (CUDA when a GPU is visible, else cpu), cpu,
    cuda or cuda:N, checked against this machine; anything else is a UserError naming
    ``flag``. Every stage and tool resolves its device here."""
    import torch

    if name == "auto":
        return "cuda" if torch.cuda.is_available() else "cpu"
    if name == "cpu":
        return name
    m = re.fullmatch(r"cuda(?::(\d+))?", str(name))
    if m is None:
        raise UserError(f"{flag} {show(name)}: must be {DEVICES}")
    if not torch.cuda.is_available():
        raise UserError(f"{flag} {show(name)}: no CUDA GPU is visible on this machine; use "
                        "--device cpu or auto")
    n = torch.cuda.device_count()
    if m.group(1) is not None and int(m.group(1)) >= n:
        raise UserError(f"{flag} {show(name)}: this machine has {n} CUDA GPU(s): use cuda:0"
                        f"{f' .. cuda:{n - 1}' if n > 1 else ''}")
    return name


# --------------------------------------------------------------------------- checks
def _number(bound: Any, cfg: Any) -> tuple[float, str]:
    """A bound's value and how to say it (another field's name becomes its option)."""
    if isinstance(bound, str):
        f = {f.name: f for f in dataclasses.fields(cfg)}[bound]
        return getattr(cfg, bound), f"{flag_of(f)} ({show(getattr(cfg, bound))})"
    return bound, show(bound)


def allowed(rules: dict, cfg: Any = None) -> str:
    """What the rules allow, in words: 'between 0 and 1', 'one of a, b or c'."""
    if "choices" in rules:
        names = list(rules["choices"]) + ([f"a {rules['suffix']} file"]
                                          if "suffix" in rules else [])
        return "one of " + ", ".join(names[:-1]) + " or " + names[-1] if len(names) > 1 \
            else names[0]
    lo = next(((k, rules[k]) for k in ("ge", "gt") if k in rules), None)
    hi = next(((k, rules[k]) for k in ("le", "lt") if k in rules), None)
    lo_s = _number(lo[1], cfg)[1] if lo else ""
    hi_s = _number(hi[1], cfg)[1] if hi else ""
    what = "an odd number " if rules.get("odd") else ""
    if lo and hi and lo[0] == "ge" and hi[0] == "le":
        return f"{what}between {lo_s} and {hi_s}"
    parts = [("at least " if lo[0] == "ge" else "more than ") + lo_s] if lo else []
    parts += [("at most " if hi[0] == "le" else "less than ") + hi_s] if hi else []
    return (what + " and ".join(parts)) if parts else (what.strip() or "a finite number")


def _fails(x: Any, rules: dict, cfg: Any) -> bool:
    """True when one value breaks the rules."""
    if isinstance(x, str | Path):
        if "choices" not in rules:
            return False
        return str(x) not in rules["choices"] and not (
            "suffix" in rules and str(x).lower().endswith(rules["suffix"]))
    if isinstance(x, bool) or not isinstance(x, int | float):
        return False
    if isinstance(x, float) and not math.isfinite(x):
        return True
    checks = {"ge": lambda b: x >= b, "gt": lambda b: x > b, "le": lambda b: x <= b,
              "lt": lambda b: x < b}
    if any(not ok(_number(rules[k], cfg)[0]) for k, ok in checks.items() if k in rules):
        return True
    return bool(rules.get("odd")) and (not isinstance(x, int) or x % 2 == 0)


def problem(cfg: Any, f: dataclasses.Field) -> str | None:
    """What is wrong with ``cfg``'s value of field ``f`` ('must be ...'), None when fine."""
    value, rules = getattr(cfg, f.name), f.metadata
    if value is None:
        return None
    if rules.get("device"):
        try:
            resolve_device(value)
        except UserError as e:
            return str(e).split(": ", 1)[1]
        return None
    items = value if isinstance(value, tuple) else (value,)
    if not any(_fails(x, rules, cfg) for x in items):
        if rules.get("exists") and isinstance(value, str | Path) \
                and str(value) not in rules.get("choices", ()) and not Path(value).is_file():
            return "no such file: give the path of an existing file"
        return None
    what = allowed(rules, cfg)
    if isinstance(value, tuple):
        count = "" if "..." in str(f.type) else f"{len(value)} "  # tuple[float, ...]: any
        kind = "names" if any(isinstance(x, str) for x in value) else "numbers"
        return f"must be {count}{kind}, each {what}"
    return f"must be {what}"


def check_field(cfg: Any, name: str, where: str | None = None) -> None:
    """UserError ``<where>: must be ...`` when field ``name`` of ``cfg`` breaks its rules;
    ``where`` defaults to ``--option value``."""
    f = {f.name: f for f in dataclasses.fields(cfg)}[name]
    bad = problem(cfg, f)
    if bad:
        where = where or f"{flag_of(f)} {show(getattr(cfg, name), f.metadata.get('sep', ','))}"
        raise UserError(f"{where}: {bad}")


def validate(cfg: Any) -> Any:
    """Check every field of the config dataclass ``cfg`` (first failure: one-line UserError
    naming the option, the value and what is allowed), then the rules between its fields
    where the class has them (a ``rules()`` method raising such a UserError, e.g. the depth
    stage's P1 <= P2); returns ``cfg``."""
    for f in dataclasses.fields(cfg):
        check_field(cfg, f.name)
    if callable(rules := getattr(cfg, "rules", None)):
        rules()
    return cfg


# --------------------------------------------------------------------------- text -> value
def coerce(text: str, tp: Any, where: str, form: str | None = None) -> Any:
    """The command-line string ``text`` as the annotated type ``tp`` (int, float, str, bool,
    Path, a tuple of those written ``a,b`` or ``AxB``, or one of them | None written none);
    a UserError starting with ``where`` when it is not one (``form``: how a tuple is
    written, e.g. WIDTHxHEIGHT)."""
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        if text.strip().lower() in ("none", "null", "") and len(args) < len(
                typing.get_args(tp)):
            return None
        return coerce(text, args[0], where, form)
    if origin is tuple:
        args = typing.get_args(tp)
        count = f"{len(args)} "
        if len(args) == 2 and args[1] is Ellipsis:
            if text.strip().lower() in ("", "none"):  # the empty tuple (`--pads none`)
                return ()
            args, count = (args[0],) * len(text.split(",")), ""
        parts = re.split(r"[,x]", text.lower()) if args[0] is int else text.split(",")
        if form:
            how = f"{count}numbers {form}" if count else f"numbers separated by commas ({form})"
        else:
            how = f"{count}numbers separated by commas{' or x' if args[0] is int else ''}"
        if len(parts) != len(args):
            raise UserError(f"{where}: must be {how}")
        try:
            return tuple(tp_(p.strip()) for p, tp_ in zip(parts, args, strict=True))
        except ValueError:
            raise UserError(f"{where}: must be {how}") from None
    try:
        if tp is bool:
            if text.lower() in ("1", "true", "yes", "on"):
                return True
            if text.lower() in ("0", "false", "no", "off"):
                return False
            raise ValueError(text)
        if tp in (int, float, str, Path):
            return tp(text)
    except ValueError:
        raise UserError(f"{where}: {show(text)} is not a valid {tp.__name__}") from None
    raise UserError(f"{where}: this option cannot be set from the command line")
