"""Options at the boundary: every bad value is one line, exit 2, nothing written.

The CLI's options are the config dataclasses' fields (pipeline/options.py,
workflows/config_cli.py)."""

from __future__ import annotations

import dataclasses
import hashlib
import math
import re
import typing
from pathlib import Path

import cv2
import numpy as np
import pytest
import typer

from pipeline.errors import UserError
from pipeline.options import check_field, coerce, flag_of, resolve_device, show, validate
from workflows.cli import app, command_names, main
from workflows.config_cli import (
    FACTORY,
    GENERATED,
    config_fields,
    help_text,
    load_class,
    repeatable,
)
from workflows.oneshot import STAGES, _stage_configs, apply_overrides


# --------------------------------------------------------------------------- fixture
def _look_at(center: np.ndarray) -> np.ndarray:
    z = -center / np.linalg.norm(center)
    x = np.cross([0.0, 1.0, 0.0], z)
    x /= np.linalg.norm(x)
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = np.stack([x, np.cross(z, x), z], 1), center
    return m


@pytest.fixture(scope="module")
def tiny(tmp_path_factory) -> tuple[Path, Path]:
    """(photo folder, posed workspace) of 4 random 40x30 views: decode and pose complete,
    nothing else (no masks, model or renders). No real data, no SfM."""
    from workflows.research.pretrain_scenes import write_workspace

    root = tmp_path_factory.mktemp("options")
    photos = root / "photos"
    photos.mkdir()
    rng = np.random.default_rng(0)
    K = np.array([[40.0, 0, 20], [0, 40, 15], [0, 0, 1]])
    views = []
    for i in range(4):
        cv2.imwrite(str(photos / f"v{i}.png"), rng.integers(0, 255, (30, 40, 3), np.uint8))
        a = -0.3 + 0.2 * i
        views.append((f"v{i}.png", K, _look_at(np.array([3 * np.sin(a), 0.0, -3 * np.cos(a)]))))
    write_workspace(root / "ws", photos, views, max_size=40,
                    box=np.array([[-1.0, -1, -1], [1, 1, 1]]))
    return photos, root / "ws"


def _snapshot(*folders: Path) -> dict[str, str]:
    """Every file and folder under ``folders`` (hidden ones too) with its content hash."""
    out = {}
    for folder in folders:
        for p in sorted(folder.rglob("*")):
            out[str(p)] = "dir" if p.is_dir() else hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def _one_line_exit_2(capsys, argv: list[str], folders: list[Path]) -> str:
    """Run the CLI: exit 2, one `error:` line and nothing else on stderr, folders unchanged."""
    before = _snapshot(*folders)
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 2, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    assert _snapshot(*folders) == before
    return lines[0]


# --------------------------------------------------------------------------- bad values
BAD = [  # (command, extra args, the line starts with)
    ("finetune", ["--device", "mps"], "error: --device mps: must be auto, cpu, cuda or cuda:N"),
    ("finetune", ["--device", "tpu9"], "error: --device tpu9: must be auto, cpu, cuda"),
    ("synth", ["--light", "nan,nan,nan"], "error: --light nan,nan,nan: must be 3 numbers, "
     "each a finite number"),
    ("synth", ["--light", "1,2"], "error: --light 1,2: must be 3 numbers X,Y,Z"),
    ("mask", ["--threshold", "1.5"], "error: --threshold 1.5: must be between 0 and 1"),
    ("select", ["--max-flare", "5"], "error: --max-flare 5: must be between 0 and 1"),
    ("render", ["--scale", "-1"], "error: --scale -1: must be more than 0"),
    ("finetune", ["--iters", "-5"], "error: --iters -5: must be at least 1"),
    ("render", ["--frames", "0"], "error: --frames 0: must be at least 1"),
    ("render", ["--samples", "0"], "error: --samples 0: must be at least 1"),
    ("finetune", ["--rays", "0"], "error: --rays 0: must be at least 1"),
    ("render", ["--size", "0x10"], "error: --size 0x10: must be 2 numbers, each at least 1"),
    ("mask", ["--scales", "1,0"], "error: --scales 1,0: must be numbers, each more than 0 and "
     "at most 2"),
    ("mask", ["--scales", "1,x"], "error: --scales 1,x: must be numbers separated by commas"),
    ("mask", ["--streak-scales", "1,0.25"],
     "error: --streak-scales sets where --streak-lines looks: add --streak-lines"),
    ("mask", ["--streak-lines", "--streak-scales", "1,0"],
     "error: --streak-scales 1,0: must be numbers, each more than 0 and"),
    ("render", ["--path", "nowhere"], "error: --path nowhere: must be one of inputs, "
     "interpolate, spiral or a .json file"),
    ("render", ["--fill", "magic"], "error: --fill magic: must be one of hybrid or network"),
    ("depth", ["--keep", "9"], "error: --keep 9: must be between 1 and --neighbours (4)"),
    ("depth", ["--window", "4"], "error: --window 4: must be an odd number at least 3"),
    ("pose", ["--matcher", "fancy"], "error: --matcher fancy: must be one of auto, "
     "exhaustive or sequential"),
    ("finetune", ["--init", "weights.pt"], "error: --init weights.pt: must be one of auto, "
     "scratch or a .safetensors file"),
    ("finetune", ["--preset", "huge"], "error: --preset huge: must be one of auto, paper"),
    ("finetune", ["--init", "missing.safetensors"], "error: --init missing.safetensors: no "
     "such file: give the path of an existing file"),
    ("mask", ["--weights", "missing.safetensors"], "error: --weights missing.safetensors: no "
     "such file"),
    ("export", ["--crf", "99"], "error: --crf 99: must be between 0 and 51"),
    ("export", ["--fps", "nan"], "error: --fps nan: must be more than 0"),
]


@pytest.mark.parametrize("cmd, args, line", BAD, ids=[f"{c} {' '.join(a)}" for c, a, _ in BAD])
def test_bad_value_is_one_line_exit_2_nothing_written(tiny, tmp_path, capsys, cmd, args, line):
    photos, ws = tiny
    out = ["--out", str(tmp_path / "flared")] if cmd == "synth" else []
    got = _one_line_exit_2(capsys, [cmd, str(ws), *out, *args], [photos, ws])
    assert got.startswith(line), got
    assert not (tmp_path / "flared").exists()


RESEARCH_BAD = [  # research commands: ({ws}, {tmp} filled in, the line starts with)
    (["eval", "{ws}", "--variants", "gnfr,nerf"],
     "error: --variants gnfr,nerf: must be one or more of gnfr, gnt, no_ps"),
    (["eval", "{ws}", "--masks", "foo"], "error: --masks foo: must be one of fmg or gt"),
    (["eval", "{ws}", "--render-scale", "0"],
     "error: --render-scale 0: must be more than 0 and at most 1"),
    (["eval", "{ws}", "--preset", "huge"], "error: --preset huge: must be one of auto, paper"),
    (["eval", "{ws}", "--device", "mps"], "error: --device mps: must be auto, cpu, cuda"),
    (["eval-llff", "{ws}", "--every", "1"], "error: --every 1: must be at least 2"),
    (["eval-llff", "{ws}", "--fill", "magic"],
     "error: --fill magic: must be one or more of hybrid, network"),
    (["fmg", "train", "--out", "{tmp}/fmg", "--without", "rain"],
     "error: --without rain: must be one or more of starburst, ghosts"),
    (["fmg", "train", "--out", "{tmp}/fmg", "--negatives", "lamp,trees"],
     "error: --negatives lamp,trees: must be one or more of lamp, specular, sky, clouds"),
    (["fmg", "eval", "--negatives", "trees"],
     "error: --negatives trees: must be one or more of lamp, specular"),
    (["fmg", "eval", "--negatives", "backlit", "--clean"],
     "error: give one of --per-kind, --work-sizes, --clean, --negatives"),
    (["fmg", "train", "--out", "{tmp}/fmg", "--night-prob", "2"],
     "error: --night-prob 2: must be between 0 and 1"),
    (["fmg", "eval", "--loo", "{tmp}/a.safetensors"], "error: --loo needs --per-kind"),
    (["fmg", "eval", "--scales", "1,0.75"], "error: --scales needs --per-kind or --clean"),
    (["fmg", "eval", "--flare-canvas", "2"], "error: --flare-canvas needs --per-kind"),
    (["fmg", "eval", "--clean", "--night", "0"], "error: --night needs --per-kind"),
    (["fmg", "eval", "--ghost-lines"], "error: --ghost-lines needs --per-kind or --clean"),
    (["fmg", "eval", "--per-kind", "--pads", "reflect"], "error: --pads needs --clean"),
    (["fmg", "eval", "--clean", "--pads-keep", "regions"],
     "error: --pads-keep says what the padded runs of --pads keep: add --pads"),
    (["fmg", "overlay", "{tmp}/a.jpg", "--out", "{tmp}/o.jpg", "--pads-keep", "regions"],
     "error: --pads-keep says what the padded runs of --pads keep: add --pads"),
    (["fmg", "eval", "--per-kind", "--ghost-chain", "1"],
     "error: --ghost-chain sets the ghost lines' rule: add --ghost-lines"),
    (["fmg", "overlay", "{tmp}/a.jpg", "--out", "{tmp}/o.jpg", "--ghost-chain", "1"],
     "error: --ghost-chain sets the ghost lines' rule: add --ghost-lines"),
    (["fmg", "train", "--out", "{tmp}/fmg", "--flare-canvas", "0.5"],
     "error: --flare-canvas 0.5: must be between 1 and 4"),
    (["fmg", "eval", "--clean", "--data", "{tmp}"], "error: {tmp}/scenes/fern/images_8: no such "
     "folder; pass --data pointing at the shared data"),
    (["fmg", "eval", "--clean", "--confirm-keep", "first"],
     "error: --confirm-keep says which regions --confirm keeps: add --confirm WEIGHTS"),
    (["pretrain", "{ws}", "--lr-restart", "0", "--out", "{tmp}/pt"],
     "error: --lr-restart 0: must be more than 0 and at most 1"),
    (["fmg", "eval", "--per-kind", "--clean"],
     "error: give one of --per-kind, --work-sizes, --clean"),
    (["fmg", "eval", "--per-kind", "--ray-min", "1"],
     "error: --ray-min, --ray-opposite, --streak-lines and --light-cores set the flare rays' "
     "rule: add --rays"),
    (["fmg", "overlay", "{tmp}/a.jpg", "--out", "{tmp}/o.jpg", "--ray-opposite", "8"],
     "error: --ray-min, --ray-opposite, --streak-lines and --light-cores set the flare rays' "
     "rule: add --rays"),
    (["fmg", "overlay", "{tmp}/a.jpg", "--out", "{tmp}/o.jpg", "--streak-lines"],
     "error: --ray-min, --ray-opposite, --streak-lines and --light-cores set the flare rays' "
     "rule: add --rays"),
    (["fmg", "overlay", "{tmp}/a.jpg", "--out", "{tmp}/o.jpg", "--rays", "--streak-scales",
      "0.25"], "error: --streak-scales sets where --streak-lines looks: add --streak-lines"),
    (["fmg", "eval", "--per-kind", "--rays", "--streak-scales", "0.25"],
     "error: --streak-scales sets where --streak-lines looks: add --streak-lines"),
    (["fmg", "calibrate", "--count", "0", "--out", "{tmp}/c.json"],
     "error: --count 0: must be at least 1"),
    (["fmg", "overlay", "{tmp}/a.jpg", "--out", "{tmp}/o.jpg", "--work-size", "0"],
     "error: --work-size 0: must be at least 32"),
    (["bench", "--steps", "0", "--out", "{tmp}/b.json"], "error: --steps 0: must be at least 1"),
    (["pretrain", "{ws}", "--flare-prob", "2", "--out", "{tmp}/pt"],
     "error: --flare-prob 2: must be between 0 and 1"),
]


@pytest.mark.parametrize("argv, line", RESEARCH_BAD,
                         ids=[" ".join(a) for a, _ in RESEARCH_BAD])
def test_research_commands_check_before_writing(tiny, tmp_path, capsys, argv, line):
    photos, ws = tiny
    argv = [a.format(ws=ws, tmp=tmp_path) for a in argv]
    got = _one_line_exit_2(capsys, argv, [photos, ws, tmp_path])
    assert got.startswith(line.format(tmp=tmp_path)), got


def test_flare_kind_choices_are_the_kinds():
    """fmg train --without lists its choices as a literal (the CLI reads it without
    importing): the kinds of pipeline.flare."""
    from pipeline.flare import KINDS
    from workflows.research.fmg_train import FMGTrainConfig

    without = {f.name: f for f in dataclasses.fields(FMGTrainConfig)}["without"]
    assert without.metadata["choices"] == KINDS


def test_cuda_that_is_not_there(tiny, capsys):
    import torch

    photos, ws = tiny
    if torch.cuda.is_available():
        name, says = f"cuda:{torch.cuda.device_count()}", "this machine has"
    else:
        name, says = "cuda", "no CUDA GPU is visible"
    got = _one_line_exit_2(capsys, ["render", str(ws), "--device", name], [photos, ws])
    assert got.startswith(f"error: --device {name}: ") and says in got, got


def test_export_with_nothing_rendered(tiny, capsys):
    photos, ws = tiny
    got = _one_line_exit_2(capsys, ["export", str(ws)], [photos, ws])
    assert "nothing rendered" in got and f"deflare-scene render {ws} --path interpolate" in got


SET_BAD = ["finetune.device=mps", "finetune.device=tpu9", "mask.threshold=1.5",
           "select.max_flare=5", "render.scale=-1", "finetune.iters=-5", "render.frames=0",
           "render.samples=0", "finetune.rays=0", "render.size=0x10", "depth.keep=9",
           "render.fps=nan"]


@pytest.mark.parametrize("item", SET_BAD)
def test_set_rejects_the_same_values(item):
    with pytest.raises(UserError) as e:
        apply_overrides(_stage_configs(), [item])
    assert str(e.value).startswith(f"--set {item}: must be "), str(e.value)


ONESHOT_BAD = [
    (["--max-flare", "5"], "error: --max-flare 5: must be between 0 and 1"),
    (["--threshold", "1.5"], "error: --threshold 1.5: must be between 0 and 1"),
    (["--device", "mps"], "error: --device mps: must be auto, cpu, cuda or cuda:N"),
    (["--iters", "-5"], "error: --iters -5: must be at least 1"),
    (["--frames", "0"], "error: --frames 0: must be at least 1"),
    (["--set", "render.samples=0"], "error: --set render.samples=0: must be at least 1"),
    (["--set", "finetune.rays=0"], "error: --set finetune.rays=0: must be at least 1"),
    (["--set", "mask.weights=missing.safetensors"], "error: --set "
     "mask.weights=missing.safetensors: no such file: give the path of an existing file"),
]


@pytest.mark.parametrize("args, line", ONESHOT_BAD, ids=[" ".join(a) for a, _ in ONESHOT_BAD])
def test_oneshot_checks_before_writing(tiny, tmp_path, capsys, args, line):
    photos, _ = tiny
    got = _one_line_exit_2(capsys, [str(photos), "--out", str(tmp_path / "ws"), *args],
                           [photos])
    assert got.startswith(line), got
    assert not (tmp_path / "ws").exists()


# --------------------------------------------------------------------------- the mechanism
def test_every_default_config_is_valid():
    for cfg in _stage_configs().values():
        validate(cfg)
    for target in {g["target"] for g in GENERATED.values() if "target" in g}:
        cls = load_class(target)
        required = {f.name: Path("x") for f in dataclasses.fields(cls)
                    if f.default is dataclasses.MISSING
                    and f.default_factory is dataclasses.MISSING}
        validate(cls(**required))


def test_one_device_resolver():
    from pipeline import finetune, render

    # every stage calls resolve_device; finetune.pick_device only makes it a torch.device
    assert resolve_device("cpu") == "cpu"
    assert resolve_device("auto") in ("cpu", "cuda")
    assert not hasattr(render, "pick_device")
    for bad in ("mps", "tpu9", "CPU", "cuda:x", "cuda0", ""):
        for fn in (resolve_device, finetune.pick_device):
            with pytest.raises(UserError, match="must be auto, cpu, cuda or cuda:N"):
                fn(bad)
    assert str(finetune.pick_device("cpu")) == "cpu"


def test_values_shown_as_typed_and_parsed_back():
    assert show(5.0) == "5" and show(0.1) == "0.1" and show(math.nan) == "nan"
    assert show((640, 360), "x") == "640x360" and show("two words") == "'two words'"
    assert coerce("640x360", tuple[int, int] | None, "--size") == (640, 360)
    assert coerce("none", int | None, "--iters") is None
    assert coerce("off", bool, "--x") is False
    for nothing in ("", "none", " None "):  # a list of any length may be empty
        assert coerce(nothing, tuple[str, ...], "--pads") == ()
    assert coerce("reflect,constant", tuple[str, ...], "--pads") == ("reflect", "constant")
    with pytest.raises(UserError, match="^--rays many: many is not a valid int$"):
        coerce("many", int, "--rays many")


def test_cross_field_rule_names_the_other_option():
    from pipeline.depth import DepthConfig

    with pytest.raises(UserError, match=r"^--keep 5: must be between 1 and --neighbours \(4\)$"):
        check_field(DepthConfig(keep=5), "keep")
    validate(DepthConfig(keep=5, neighbours=6))


def _click_command(name: str):
    command_names()  # registers every command
    group = typer.main.get_command(app)
    cmd = group.commands[name.split()[0]]
    for part in name.split()[1:]:
        cmd = cmd.commands[part]
    return cmd


def _field_default(f: dataclasses.Field):
    if f.default is not dataclasses.MISSING:
        return f.default
    return FACTORY if f.default_factory is not dataclasses.MISSING else ...


UNREACHABLE = {("synth", "flare"): "flare ranges: Python API; --kinds sets flare.kinds",
               ("bench", "devices"): "--device all|cpu|cuda sets devices",
               ("eval", "finetune_extra"): "extra FinetuneConfig fields: Python API",
               ("eval-llff", "finetune_extra"): "extra FinetuneConfig fields: Python API",
               ("fmg train", "weight_decay"): "never a flag of fmg train: Python API",
               ("fmg train", "seed"): "never a flag of fmg train: Python API"}


def _leaf_commands() -> list[str]:
    """Every command of the CLI by its full name ("fmg eval"), groups left out."""
    command_names()
    out = []

    def walk(cmd, path: list[str]) -> None:
        subs = getattr(cmd, "commands", None)
        if subs is None:
            out.append(" ".join(path))
        for name, sub in (subs or {}).items():
            walk(sub, [*path, name])

    walk(typer.main.get_command(app), [])
    return out


def test_every_command_is_generated_from_a_config():
    """No command restates its options by hand: each is built by config_command or
    fields_command (workflows/config_cli.py), research tools included."""
    leaves = _leaf_commands()
    assert {"eval", "eval-llff", "fmg train", "fmg eval", "fmg calibrate", "fmg overlay",
            "bench", "pretrain", "run", "render"} <= set(leaves)
    assert sorted(set(leaves) - set(GENERATED)) == []


def test_generated_options_are_the_dataclass_fields():
    """Every field of a generated command's config is an option of the same name, default and
    help (or a documented exception), and the command has no other options."""
    command_names()
    for name in STAGES:  # every stage command is generated from the one-shot's config
        assert GENERATED[name]["target"] == STAGES[name]
    for name, info in GENERATED.items():
        if "target" not in info:
            continue
        cls = load_class(info["target"])
        specs = {s.name: s for s in config_fields(info["target"])}
        params = {p.name: p for p in _click_command(name).params}
        assert set(specs) == {f.name for f in dataclasses.fields(cls)}, name
        for f in dataclasses.fields(cls):
            if f.name in info["explicit"]:
                assert f.name in params, (name, f.name)
                continue
            if (name, f.name) in UNREACHABLE:
                assert f.name not in params
                continue
            p = params.pop(f.name)  # KeyError: a field the command cannot reach
            flag = flag_of(f).split("/")
            assert flag[0] in p.opts and flag[1:] in ([], p.secondary_opts), (name, f.name)
            default = _field_default(f)
            if repeatable(specs[f.name]):  # --loo A --loo B
                assert p.multiple and p.default is None and default == (), (name, f.name)
            elif default is ...:
                assert p.required, (name, f.name)
            elif default is FACTORY:
                assert p.default is None, (name, f.name)
            elif isinstance(default, tuple):
                assert p.default == show(default, f.metadata.get("sep", ",")), (name, f.name)
            else:
                assert p.default == default and type(p.default) is type(default), \
                    (name, f.name, p.default, default)
            assert p.help and p.help == help_text(specs[f.name], tuple(specs.values()))
        explicit = set(info["explicit"]) | {"help"}
        assert set(params) <= explicit, (name, set(params) - explicit)


def test_oneshot_flags_and_set_reach_every_field():
    from workflows.commands.run import FLAGS

    command_names()
    params = {p.name: p for p in _click_command("run").params}
    defaults = _stage_configs()
    for name, stages in FLAGS.items():
        for stage in stages:
            f = {f.name: f for f in dataclasses.fields(defaults[stage])}[name]
            assert flag_of(f) in params[name].opts
            if name != "fps":  # None: 24 with CUDA, 12 on CPU (oneshot.default_fps)
                assert params[name].default == getattr(defaults[stage], name), name
    for stage, cfg in defaults.items():  # --set parses every field back to its value
        hints = typing.get_type_hints(type(cfg))
        for f in dataclasses.fields(cfg):
            if dataclasses.is_dataclass(hints[f.name]):
                continue
            value = getattr(cfg, f.name)
            text = "none" if value is None else show(value, f.metadata.get("sep", ","))
            got = apply_overrides(defaults, [f"{stage}.{f.name}={text.strip(chr(39))}"])
            assert getattr(got[stage], f.name) == value, (stage, f.name)


DOC_PAGES = ("README.md", "docs/options.md", "docs/presets.md", "docs/depth.md",
             "gnfr/weights/fmg.md", "gnfr/weights/gnfr.md")


@pytest.mark.parametrize("page", DOC_PAGES)
def test_every_set_option_the_user_docs_quote_parses(page):
    """Each `--set STAGE.FIELD=VALUE` a user page suggests is an option the one-shot accepts
    with that value (a renamed option or a bad value in the docs fails here)."""
    text = (Path(__file__).resolve().parents[2] / page).read_text()
    items = re.findall(r"--set ([a-z_]+\.[a-z_]+=[^\s`)]+)", text)
    if page in ("README.md", "docs/options.md"):
        assert len(items) >= 5, f"{page} quotes {items}"
    for item in items:
        apply_overrides(_stage_configs(), [item])  # raises UserError on a bad one
