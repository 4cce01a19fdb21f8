"""Typer options generated from config dataclasses: one source for names, defaults and help.

``@config_command(app, "select", "pipeline.select:SelectConfig")`` registers a function
``fn(config, workspace, force)`` as a command whose options are the fields of the config:
the name is the field's ``flag`` rule or ``--field-name`` (pipeline/options.py), the default
the field's default, the help the field's docstring. The class is read from its source with
``ast`` (cached), so ``--help`` does not import the stage (or torch); defaults must therefore
be literals, ``Path("...")`` or ``option(literal, ...)`` (tests/workflows/test_options.py checks the
generated options against the imported dataclass). When the command runs, the config is
built from the options and ``validate``d before ``fn`` is called.

Parameters of ``fn`` other than ``config`` (the workspace argument, --force, a typer.Context)
stay explicit; the generated options are listed where ``config`` stands among them (after
the arguments); an explicit parameter named like a field replaces that field's option and
its value goes into the config. ``fields_command`` does the same for options picked from
several configs (the one-shot command).
"""

from __future__ import annotations

import ast
import dataclasses
import functools
import importlib
import importlib.util
import inspect
import re
import typing
from collections.abc import Callable
from pathlib import Path
from typing import Any

import typer
from rich.markup import escape

from pipeline.errors import UserError
from pipeline.options import RULES, coerce, show

REQUIRED = ...  # a field without a default: a required option
FACTORY = object()  # a default the source does not spell as a literal: left to the config
_NAMES = {"Path": Path, "tuple": tuple, "list": list, "dict": dict, "Any": Any,
          "int": int, "float": float, "str": str, "bool": bool, "None": None}


@dataclasses.dataclass(frozen=True)
class FieldSpec:
    """One field of a config dataclass as the CLI sees it."""

    name: str
    type: Any  # the resolved annotation; None when the CLI cannot set it
    default: Any  # REQUIRED, FACTORY or the value
    doc: str
    rules: dict

    @property
    def flag(self) -> str:
        return self.rules.get("flag") or "--" + self.name.replace("_", "-")

    @property
    def base(self) -> Any:
        """The annotation without ``| None``."""
        args = [a for a in typing.get_args(self.type) if a is not type(None)]
        return args[0] if _is_optional(self.type) and len(args) == 1 else self.type


def _is_optional(tp: Any) -> bool:
    return type(None) in typing.get_args(tp)


# --------------------------------------------------------------------------- reading
def _literal(node: ast.expr | None) -> Any:
    if node is None:
        return REQUIRED
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and \
            node.func.id == "Path" and len(node.args) == 1:
        return Path(_literal(node.args[0]))
    try:
        return ast.literal_eval(node)
    except ValueError:
        return FACTORY


def _default_and_rules(node: ast.expr | None) -> tuple[Any, dict]:
    """A field's default and rules from ``= value``, ``= option(...)`` or ``= field(...)``."""
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and \
            node.func.id in ("option", "field"):
        kw = {k.arg: k.value for k in node.keywords if k.arg}
        default = _literal(node.args[0] if node.args else kw.get("default"))
        if default is REQUIRED and "default_factory" in kw:
            default = FACTORY
        rules = {k: _literal(v) for k, v in kw.items() if k in RULES}
        if node.func.id == "field" and isinstance(kw.get("metadata"), ast.Dict):
            rules.update(_literal(kw["metadata"]))
        return default, {k: v for k, v in rules.items() if v is not FACTORY}
    return _literal(node), {}


def _annotation(text: str) -> Any:
    try:
        return eval(text, {"__builtins__": {}}, _NAMES)  # noqa: S307 (names above only)
    except (NameError, TypeError, SyntaxError):
        return None


@functools.cache
def config_fields(target: str) -> tuple[FieldSpec, ...]:
    """The fields of ``"package.module:ClassName"`` read from its source (not imported)."""
    module, _, cls_name = target.partition(":")
    origin = importlib.util.find_spec(module).origin
    tree = ast.parse(Path(origin).read_text(encoding="utf-8"))
    cls = next((n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == cls_name),
               None)
    if cls is None:
        raise LookupError(f"{cls_name} is not a class of {origin}")
    specs = []
    for i, node in enumerate(cls.body):
        if not (isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name)):
            continue
        text = ast.unparse(node.annotation)
        if text.startswith(("ClassVar", "typing.ClassVar")):
            continue
        nxt = cls.body[i + 1] if i + 1 < len(cls.body) else None
        doc = nxt.value.value if isinstance(nxt, ast.Expr) and isinstance(
            nxt.value, ast.Constant) and isinstance(nxt.value.value, str) else ""
        default, rules = _default_and_rules(node.value)
        specs.append(FieldSpec(node.target.id, _annotation(text), default, doc, rules))
    return tuple(specs)


def load_class(target: str) -> type:
    module, _, cls_name = target.partition(":")
    return getattr(importlib.import_module(module), cls_name)


def help_text(spec: FieldSpec, specs: tuple[FieldSpec, ...] = ()) -> str:
    """The field's docstring as one paragraph of option help, where a sibling field's name in
    double backticks becomes its option (--name)."""
    flags = {s.name: s.flag for s in specs}
    text = re.sub(r"``([^`]+)``", lambda m: flags.get(m.group(1), m.group(1)),
                  " ".join(spec.doc.split()))
    return escape(text)


# --------------------------------------------------------------------------- typer params
def repeatable(spec: FieldSpec) -> bool:
    """Whether the field is a ``tuple[Path, ...]``: an option given once per path."""
    return typing.get_origin(spec.base) is tuple and typing.get_args(spec.base) == (Path, ...)


def settable(spec: FieldSpec) -> bool:
    """Whether the CLI can write this field (a number, text, path, flag, tuple of them or
    repeated paths)."""
    base = spec.base
    if base in (int, float, str, bool, Path) or repeatable(spec):
        return True
    args = typing.get_args(base)
    return typing.get_origin(base) is tuple and bool(args) and all(
        a in (int, float, str, Ellipsis) for a in args)


def _option(spec: FieldSpec, specs: tuple[FieldSpec, ...], *, name: str | None = None,
            default: Any = FACTORY, help_prefix: str = "", help: str | None = None,
            aliases: tuple[str, ...] = ()) -> inspect.Parameter:
    """The typer option of ``spec`` as an inspect.Parameter named ``name``."""
    default = spec.default if default is FACTORY else default
    text = help_prefix + (help if help is not None else help_text(spec, specs))
    if spec.base is bool:
        decls = (spec.flag if "/" in spec.flag else f"{spec.flag}/--no-{spec.flag[2:]}",)
        tp: Any = bool if default in (True, False) else typing.Optional[bool]  # noqa: UP045
        value = default
    elif repeatable(spec):  # --loo A --loo B: a list, made a tuple by _value
        decls, tp, value = (spec.flag,), typing.Optional[list[Path]], None  # noqa: UP045
    elif typing.get_origin(spec.base) is tuple:  # typed as text, parsed by options.coerce
        decls, tp = (spec.flag,), typing.Optional[str]  # noqa: UP045
        value = show(default, spec.rules.get("sep", ",")) if isinstance(default, tuple) \
            else default
    else:
        decls = (spec.flag,)
        tp = spec.base if default not in (None, FACTORY) else typing.Optional[spec.base]  # noqa: UP045
        value = default
    value = None if value is FACTORY else value
    info = typer.Option(value, *decls, *aliases, help=text, metavar=spec.rules.get("metavar"),
                        show_default=default not in (None, FACTORY, REQUIRED, ()))
    return inspect.Parameter(name or spec.name, inspect.Parameter.KEYWORD_ONLY, default=info,
                             annotation=tp)


def _value(spec: FieldSpec, given: Any) -> Any:
    """An option's value as the field's type. Repeated paths arrive as a list; other tuples
    as text, parsed by ``coerce`` (blank text is the empty tuple where that is the field's
    default) and, for text items with ``choices``, each item checked here: ``validate``
    words its message for numbers."""
    if repeatable(spec):
        return tuple(given or ())
    if not (isinstance(given, str) and typing.get_origin(spec.base) is tuple):
        return given
    if not given.strip() and spec.default == ():
        return ()
    where = f"{spec.flag} {show(given)}"
    value = coerce(given, spec.type, where, spec.rules.get("metavar"))
    choices = spec.rules.get("choices")
    if isinstance(choices, tuple) and any(item not in choices for item in value):
        raise UserError(f"{where}: must be one or more of {', '.join(choices)}, "
                        "comma-separated")
    return value


def _explicit_value(spec: FieldSpec, given: Any) -> Any:
    """An explicit parameter's value for the config: a list (a typer argument of several
    values) becomes the tuple the field holds."""
    if isinstance(given, list) and typing.get_origin(spec.base) is tuple:
        return tuple(given)
    return given


def _explicit(fn: Callable, skip: str) -> tuple[list[inspect.Parameter],
                                             list[inspect.Parameter]]:
    """``fn``'s own parameters before and after ``skip`` (where the generated options go),
    keyword-only, annotations evaluated."""
    before: list[inspect.Parameter] = []
    after: list[inspect.Parameter] = []
    seen = False
    for p in inspect.signature(fn).parameters.values():
        if p.name == skip:
            seen = True
            continue
        tp = p.annotation
        if isinstance(tp, str):
            tp = eval(tp, fn.__globals__)  # noqa: S307 (the command module's own annotation)
        (after if seen else before).append(
            p.replace(kind=inspect.Parameter.KEYWORD_ONLY, annotation=tp))
    return before, after


def _register(app: typer.Typer, name: str, fn: Callable, params: list[inspect.Parameter],
              call: Callable[[dict], Any]) -> None:
    """Register a command ``name`` with ``params`` (arguments first) that runs ``call``."""
    def is_arg(p: inspect.Parameter) -> bool:
        return isinstance(p.default, typer.models.ArgumentInfo)

    params = [p for p in params if is_arg(p)] + [p for p in params if not is_arg(p)]

    def command(**kwargs: Any) -> Any:
        return call(kwargs)

    command.__signature__ = inspect.Signature(params)  # type: ignore[attr-defined]
    command.__annotations__ = {p.name: p.annotation for p in params}
    command.__doc__, command.__name__ = fn.__doc__, fn.__name__
    command.__module__ = fn.__module__
    app.command(name)(command)


GENERATED: dict[str, dict] = {}
"""What each generated command was built from (tests/workflows/test_options.py walks it)."""


def config_command(app: typer.Typer, name: str, target: str, *, exclude: tuple[str, ...] = (),
                   aliases: dict[str, tuple[str, ...]] | None = None,
                   group: str = "") -> Callable:
    """Decorator: ``fn(config, **explicit)`` becomes command ``name`` with one option per
    field of ``target`` ("module:Class") that the CLI can set, except ``exclude`` (fields
    left at their default) and those ``fn`` declares itself. ``group``: the name of the
    command group ``app`` is (``fmg``), so GENERATED knows the command as ``fmg eval``."""
    from pipeline.options import validate

    def deco(fn: Callable) -> Callable:
        specs = config_fields(target)
        before, after = _explicit(fn, "config")
        own = {p.name for p in before + after}
        gen = [s for s in specs if s.name not in own and s.name not in exclude and settable(s)]
        into_config = [s for s in specs if s.name in own]
        params = before + [_option(s, specs, aliases=(aliases or {}).get(s.name, ()))
                           for s in gen] + after

        def call(kwargs: dict) -> Any:
            values = {s.name: _value(s, kwargs.pop(s.name)) for s in gen}
            values.update({s.name: _explicit_value(s, kwargs.pop(s.name)) for s in into_config})
            factory = {s.name for s in specs if s.default is FACTORY}
            given = {k: v for k, v in values.items() if not (v is None and k in factory)}
            config = validate(load_class(target)(**given))
            return fn(config=config, **kwargs)

        _register(app, name, fn, params, call)
        GENERATED[f"{group} {name}".strip()] = {"target": target, "exclude": tuple(exclude),
                           "explicit": tuple(sorted(own)), "options": [s.name for s in gen]}
        return fn

    return deco


@dataclasses.dataclass(frozen=True)
class Pick:
    """An option of ``fields_command``: field ``field`` of ``target``, under ``name``."""

    target: str
    field: str
    name: str = ""
    default: Any = FACTORY  # FACTORY: the field's own default
    help_prefix: str = ""
    help: str | None = None

    @property
    def param(self) -> str:
        return self.name or self.field

    def spec(self) -> FieldSpec:
        return next(s for s in config_fields(self.target) if s.name == self.field)


def fields_command(app: typer.Typer, name: str, picks: list[Pick]) -> Callable:
    """Decorator: ``fn(values, **explicit)`` becomes command ``name`` with the options
    ``picks`` (``values``: parameter name -> value of the field's type)."""
    def deco(fn: Callable) -> Callable:
        before, after = _explicit(fn, "values")
        params = before + [_option(pk.spec(), config_fields(pk.target), name=pk.param,
                                   default=pk.default, help_prefix=pk.help_prefix,
                                   help=pk.help) for pk in picks] + after

        def call(kwargs: dict) -> Any:
            values = {pk.param: _value(pk.spec(), kwargs.pop(pk.param)) for pk in picks}
            return fn(values=values, **kwargs)

        _register(app, name, fn, params, call)
        GENERATED[name] = {"picks": list(picks),
                           "explicit": tuple(p.name for p in before + after)}
        return fn

    return deco
