"""benchmarks/gpu_session.sh, the script a lent CUDA machine runs, against today's code.

A GPU session has 15 minutes of device time and may come rarely; a stale option in the
script (a command's option renamed or removed here since it last ran) would spend one of its
calls on a usage error. These tests read the script and check, without a GPU, that every
`deflare-scene` command it runs takes each option it passes, that the benchmark scripts it
runs take theirs, and that what its inline Python imports exists and takes the keywords it
is called with."""

from __future__ import annotations

import importlib
import inspect
import re

import pytest
import typer.main

from tests.conftest import REPO

SCRIPT = REPO / "benchmarks" / "gpu_session.sh"
OPTION = re.compile(r"(?<![\w-])--[a-z][a-z0-9-]*")


def _commands() -> list[str]:
    """The script's logical lines (continuations joined), comments left out."""
    text = SCRIPT.read_text().replace("\\\n", " ")
    return [ln.split(" #")[0] for ln in text.splitlines() if not ln.lstrip().startswith("#")]


def _arrays() -> dict[str, list[str]]:
    """The options the script puts in bash arrays (``w=(--without $k)``, ``loo+=(--loo
    ...)``), by array name: a call passes them as ``"${w[@]}"``."""
    found: dict[str, list[str]] = {}
    for name, body in re.findall(r"(?<![\w-])(\w+)\+?=\(([^)]*)\)", "\n".join(_commands())):
        found.setdefault(name, []).extend(OPTION.findall(body))
    return found


def _cli_calls() -> list[tuple[tuple[str, ...], list[str]]]:
    """(subcommand path, the options passed) of every `deflare-scene` call: ``python3 -m
    workflows.cli ...`` or the script's ``cli ...`` helper, with the options of the arrays
    it expands."""
    arrays = _arrays()
    calls = []
    for line in _commands():
        for m in re.finditer(r"(?:python3 -m workflows\.cli|(?<![\w-])cli)\s+([a-z][a-z-]*)"
                             r"(?:\s+(train|eval|calibrate|overlay))?([^|&;]*)", line):
            path = (m.group(1),) + ((m.group(2),) if m.group(2) else ())
            rest = re.split(r"\s\d?>", m.group(3))[0]  # up to the output redirections
            expanded = [o for a in re.findall(r"\$\{(\w+)\[@\]\}", rest) for o in arrays[a]]
            calls.append((path, OPTION.findall(rest) + expanded))
    return calls


def _accepted(path: tuple[str, ...]) -> set[str]:
    """Every option string the CLI's command at ``path`` takes."""
    from workflows.cli import _register_all, app

    _register_all()
    cmd = typer.main.get_command(app)
    for name in path:
        cmd = cmd.commands[name]
    return {o for p in cmd.params for o in (*p.opts, *p.secondary_opts)}


def test_every_deflare_scene_call_in_the_gpu_script_takes_its_options():
    calls = _cli_calls()
    paths = {path for path, _ in calls}
    # the script's phases run these; fewer found means the parsing above lost some
    assert {("pretrain",), ("fmg", "train"), ("fmg", "calibrate"), ("fmg", "eval"),
            ("eval-llff",), ("bench",)} <= paths, paths
    assert sum(len(opts) for _, opts in calls) >= 60
    passed = {o for _, opts in calls for o in opts}
    assert {"--loo", "--without", "--init"} <= passed  # through the arrays
    for path, opts in calls:
        unknown = sorted(set(opts) - _accepted(path))
        assert not unknown, f"`deflare-scene {' '.join(path)}` does not take {unknown}"


def test_the_benchmark_scripts_the_gpu_script_runs_take_their_options():
    runs = [(m.group(1), OPTION.findall(re.split(r"\s\d?>", m.group(2))[0]))
            for line in _commands()
            for m in re.finditer(r"python3 (benchmarks/\w+\.py)([^|&;]*)", line)]
    assert {name for name, _ in runs} >= {"benchmarks/finetune_ab.py",
                                          "benchmarks/render_compile.py"}
    for name, opts in runs:
        source = (REPO / name).read_text()
        missing = [o for o in opts if f'"{o}"' not in source]
        assert opts and not missing, f"{name} does not define {missing}"


def test_the_gpu_scripts_inline_python_imports_what_exists_with_its_keywords():
    text = SCRIPT.read_text().replace("\\\n", "")
    snippets = re.findall(r'python3 -c "([^"]*)"', text)
    imported = 0
    for code in snippets:
        for module, names in re.findall(r"from (workflows\.[\w.]+|pipeline\.[\w.]+) import "
                                        r"([\w, ]+);", code):
            mod = importlib.import_module(module)
            for name in (n.strip() for n in names.split(",")):
                fn = getattr(mod, name, None)
                assert fn is not None, f"{module} has no {name}"
                imported += 1
                params = inspect.signature(fn).parameters
                for call in re.findall(rf"{name}\(([^;]*)\)", code):
                    for kw in re.findall(r"(?<![\w'])(\w+)=", call):
                        assert kw in params, f"{module}.{name} takes no {kw}="
    assert imported >= 3  # export_fp16 (twice) and export_checkpoint (twice)


@pytest.mark.parametrize("named, path", [
    ("tests/gnfr/test_gpu.py", "tests/gnfr/test_gpu.py"),
    ("workflows.research.scene_pack", "workflows/research/scene_pack.py"),
    ("workflows.research.pretrain_scenes", "workflows/research/pretrain_scenes.py"),
    ("benchmarks/device_slim.sh", "benchmarks/device_slim.sh"),
    ("benchmarks/build_dev_scenes.sh", "benchmarks/build_dev_scenes.sh"),
])
def test_the_files_the_gpu_script_names_exist(named, path):
    assert named in SCRIPT.read_text()
    assert (REPO / path).exists()


RUNBOOK = REPO / "docs" / "gpu.md"


def _runbook_blocks() -> list[str]:
    """docs/gpu.md's command blocks, continuations joined."""
    return [b.replace("\\\n", " ") for b in re.findall(r"```\n(.*?)```", RUNBOOK.read_text(),
                                                       re.S)]


def test_the_gpu_runbooks_call_uses_what_the_script_reads():
    """docs/gpu.md's call: each variable it sets is one the script reads, the phases it
    names are the script's, and the file it starts the FMG from exists; its dry run here
    is the same call on the CPU."""
    script = SCRIPT.read_text()
    prep, call, dry = _runbook_blocks()
    env = dict(re.findall(r"(?<![\w$])([A-Z_]+)=(\S+)", call))
    dry_env = dict(re.findall(r"(?<![\w$])([A-Z_]+)=(\S+)", dry))
    assert dry_env["DEV"] == "cpu" and "gpu_session.sh session" in dry
    assert {k: v for k, v in dry_env.items() if k in env and k != "FMG_WORKERS"} == {
        k: v for k, v in env.items() if k != "FMG_WORKERS"}  # the recipe, as called
    local = {"OUT", "CKPT", "DEV", "FM", "PT", "OMP_NUM_THREADS", "FMG_BATCH"}
    for name in set(dry_env) - set(env) - {"OMP_NUM_THREADS", "OUT"}:
        assert name in local and "${" + name in script, name
    assert {"FMG_FROM", "FMG_LR", "FMG_FRAMES", "FMG_KINDS", "FMG_NIGHT_GLARE"} <= set(env)
    for name in env:
        assert "${" + name in script, f"gpu_session.sh does not read {name}"
    assert (REPO / env["FMG_FROM"]).exists()
    phases = set(re.findall(r"^([a-z]+)\)", script, re.M))
    text = RUNBOOK.read_text()
    named = set(re.findall(r"(?:gpu_session\.sh |`)([a-z]+) \d+", text))
    assert {"session", "train", "fern"} <= named <= phases, (named, phases)


def test_the_gpu_runbooks_held_files_are_none_the_call_reads():
    """The files docs/gpu.md holds back for the call are none of those the `session` phase
    reads (the `paper` prior, the FMG's start), and what it carries is what it prepared."""
    prep, call = _runbook_blocks()[:2]
    slim = prep[prep.index("device_slim.sh out"):]
    held, carry = (part.split() for part in slim.split("device_slim.sh out")[1].split(" -- "))
    env = dict(re.findall(r"(?<![\w$])([A-Z_]+)=(\S+)", call))
    for path in held:
        assert (REPO / path).exists(), path
        for read in ("gnfr/weights/gnfr_paper.safetensors", env["FMG_FROM"],
                     "benchmarks", "workflows", "pipeline", "gnfr/fmg.py"):
            assert not read.startswith(path.rstrip("/") + "/") and read != path, (path, read)
    made = set(re.findall(r"(\.carry/\w+)", prep[:prep.index("device_slim.sh")]))
    assert set(carry) == made == {".carry/fmgdata", ".carry/fern", ".carry/whl"}
    assert all(f'"{c}"' in RUNBOOK.read_text() for c in carry)  # the run's carry list
    # the FMG's CUDA test finds a full-width file among those that travel
    gpu_test = (REPO / "tests/gnfr/test_gpu.py").read_text()
    assert any(n in gpu_test and f"gnfr/weights/{n}" not in held
               for n in ("fmg_candidate_F26.safetensors",))


def test_the_gpu_runbooks_fern_speeds_are_the_files():
    from tests.docs.numbers import result

    text = " ".join(RUNBOOK.read_text().split())
    for name, fmt in (("fern_llff_paper_cuda_h200_s77.json", "1 500 took {:.0f} s"),
                      ("fern_llff_paper_cuda_h200_s78.json", "{rate:.2f} steps/s")):
        run = result(name)["clean"]
        secs = run["methods"]["gnfr_network"]["provenance"]["trained"]["train_seconds"]
        steps = run["budget"]["iters"]
        assert fmt.format(secs, rate=steps / secs) in text, (name, steps, secs)
    s78 = result("fern_llff_paper_cuda_h200_s78.json")
    fine = s78["clean"]["methods"]["gnfr_network"]["provenance"]["trained"]["train_seconds"]
    assert f"took {s78['seconds']:.0f} s for {fine:.0f} s of fine-tuning" in text
