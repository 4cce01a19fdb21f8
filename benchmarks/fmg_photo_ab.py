"""The photo part of an FMG candidate's rule: two mask networks' de-flared photos, same scenes.

Each arm copies a development synth scene's evaluated workspace (``SYNTH/eval.ws``, the
variants left out), writes its masks with its own weights (each file at its stored cut,
flare rays on), then runs depth, select, the `quick` fine-tune (3,000 steps, seed S),
the de-flared inputs and the held-out cameras' renders, and scores them as `eval` does
(``benchmarks/score_workspace.py``). Both arms run on the scenes as built on this machine:
committed numbers of another build are not comparable (docs/history/fmg.md, "Twenty-third
session").

    python benchmarks/fmg_photo_ab.py run SYNTH --arm NAME --weights W --seed S --work DIR \
        [--[no-]holes-as-flare] [--novel-equal-below F] [--mask-args=--crosscheck] \
        [--select-args "--max-flare 0.15"] [--finetune-args=--full-res-colour] \
        [--depth-args "--sgm 0.1,1"] [--render-args=--bf16] [--keys]
        # writes DIR/fmg_NAME_fair_<scene>_s<S>.json; --keys (run and rerender): the
        # photos' own cameras rendered as novel frames too and scored (``keys_path_json``)
    python benchmarks/fmg_photo_ab.py rerender SYNTH --from-arm BASE --arm NAME --seed S \
        --work DIR [--depth-args "--sgm 0.1,1"] [--render-args=--bf16] \
        [--novel-args "--sources-equal-below 1"] [--inputs-args "--n-sources 12"] [--keys]
        # BASE's workspace copied, the depth stage rerun with the options (if any), the
        # de-flared photos and held-out cameras rendered again with BASE's model (with the
        # render options; --novel-args: the held-out cameras' render only; --inputs-args:
        # the de-flared photos' only); scored as ``run``
    python benchmarks/fmg_photo_ab.py judge DIR --candidate NAME --baseline NAME \
        [--scenes sceaux,et,lund] [--seeds 0,1] [--baseline-seeds 0,1] \
        [--held-baseline SCENE=ARM] [--rule flare|novel|depth|frames|speed|keys|keys-guard]
        [--out JSON]
        # an arm may be NAME:2,3+OTHER:4,5: one setting's runs under two names, each with
        # its own seeds (e.g. the same defaults run again in a later session on new seeds)
    python benchmarks/fmg_photo_ab.py spread DIR --arm NAME [--scenes ...] [--seeds 2,3,4]
        [--out JSON]
        # one setting's seed-to-seed spread per scene, and the standard error it gives a
        # judge's mean difference of two arms of 2 and 4 seeds (no change behind it)

``judge`` reads both arms' files and applies the photo rule of fmg.md (thresholds below):
(a) mean flare-region gain >= +0.10 dB, (b) no scene's flare region lower by more than
0.20 dB, (c) whole photo mean not lower by more than 0.05 dB and SSIM by more than 0.002,
(d) novel views not lower by more than 0.10 dB (``--held-baseline SCENE=ARM``: against
another baseline arm on that scene, e.g. one trained on the same targets as the candidate).
``--rule novel`` judges a change made for the novel views (the video) instead: (a) mean
novel-view gain >= +0.10 dB, (b) no scene's novel views lower by more than 0.20 dB, (c) the
de-flared photos' flare region and whole photo (means) not lower by more than 0.05 dB and
SSIM by more than 0.002 (docs/presets.md, "Full-size colours in the fine-tune").
``--rule depth`` judges a change of the depth stage with the model held fixed (``rerender``
arms against their ``run`` arm), with the thirty-seventh session's thresholds (docs/history/
fill.md, "Consistency in planes"): (a) mean flare-region gain >= +0.05 dB, no scene's flare
region or whole photo lower by more than 0.05 dB nor its SSIM by more than 0.002; (b) novel
views' mean PSNR not lower by more than 0.05 dB nor their mean SSIM by more than 0.002.
``--rule speed`` judges a change made for speed (the forty-eighth session's bf16 on the CPU):
no gain asked, only that nothing users see is lost beyond a seed's spread: (a) the de-flared
photos' flare region not lower by more than 0.05 dB on the mean nor 0.20 dB on any scene, (b)
the whole photo not lower by more than 0.05 dB nor SSIM by more than 0.002 (means), (c) the
novel views not lower by more than 0.10 dB (mean).
``--rule frames`` judges a depth change made for the novel frames alone (``rerender`` arms;
the de-flared photos are not judged: the change leaves them as they were), with the
forty-fourth session's thresholds (docs/history/fill.md, "The aggregated depth for the
novel frames alone"): (a) the novel views' mean SSIM gain >= +0.008, no scene's SSIM lower
by more than 0.002; (b) their mean PSNR not lower by more than 0.05 dB, no scene's lower by
more than 0.10 dB.
``--rule keys`` judges a render change for the frames near the photos (``--keys`` arms,
the model held fixed; the forty-ninth session's key blend): (a) the frames at the photos'
cameras +0.20 dB on the mean and no scene lower by more than 0.05 dB, (b) their flare region
not lower by more than 0.10 dB (mean), (c) the held-out views not lower by more than 0.05 dB
on the mean nor 0.20 dB on any scene; ``--rule keys-guard`` asks lightly flared scenes only
that the frames at the photos' cameras (0.05 dB) and their flare region (0.10 dB) not fall on
the mean and (c).
``--rule reach`` judges a change of the key blend itself (its reach, occlusion test, falloff)
against today's (``--keys`` arms, the model held fixed; the fiftieth session): (a) the
held-out views +0.05 dB on the mean and no scene lower by more than 0.10 dB, (b) their SSIM
not lower by more than 0.002 (mean), (c) the frames at the photos' cameras and their flare
region not lower by more than 0.05 and 0.10 dB (means); ``--rule reach-guard`` asks scenes
already seen (a') the held-out views not lower by more than 0.05 dB on the mean nor 0.20 dB
on any scene, and (b), (c).
About 10 minutes per run on one CPU thread.

Baselines: an arm runs the fine-tune's defaults of its code. Since commit a1f0517 those sample
full-size colours, so the committed shipped-default arm to compare a new arm with is
``s29_frc`` (seeds 2, 3, 4 on sceaux, et, lund); the ``s26_Mp`` files are the quarter-colour
defaults before it (pass ``--finetune-args=--no-full-res-colour`` to compare with them).
The latest: ``s69_sh:2,3+s73_sh:4,5`` are the defaults up to the seventy-second session (the
mask network's plain run alone; ``--mask-args="--pads none"`` to compare with them),
``s72_pad:2,3+s73_pad:4,5`` today's defaults (the padded runs' agreement pixel by pixel,
since the seventy-third session) and ``s72_reg:2,3+s73_reg:4,5`` its regions form. A
fine-tune repeats to the digit, but any change moves a run as another seed does: ``spread``
measures by how much (docs/eval.md).
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

RULE = {"flare_gain": 0.10, "flare_scene_loss": 0.20, "whole_loss": 0.05, "ssim_loss": 0.002,
        "held_loss": 0.10}
"""The photo rule's thresholds (gnfr/weights/fmg.md, JH and later candidates)."""
RULE_NOVEL = {"held_gain": 0.10, "held_scene_loss": 0.20, "flare_loss": 0.05,
              "whole_loss": 0.05, "ssim_loss": 0.002}
"""``--rule novel``'s thresholds: a change for the novel views that must not cost the photos."""


RULE_KEYS = {"keys_gain": 0.20, "keys_scene_loss": 0.05, "keys_flare_loss": 0.10,
             "held_loss": 0.05, "held_scene_loss": 0.20}
"""``--rule keys``' thresholds (the forty-ninth session's rule for the novel frames' sources
near flared photos, the model held fixed): the video's frames at the photos' own cameras
(``--keys``) and the held-out views; ``--rule keys-guard`` asks the lightly flared scenes only
that nothing is lost (docs/history/fill.md, "Novel frames' sources near heavily flared
photos")."""


RULE_REACH = {"held_gain": 0.05, "held_scene_loss": 0.10, "held_ssim_loss": 0.002,
              "keys_loss": 0.05, "keys_flare_loss": 0.10, "guard_held_loss": 0.05,
              "guard_held_scene_loss": 0.20}
"""``--rule reach``'s thresholds (the fiftieth session's rules for the key blend's reach, its
occlusion test and its falloff against today's key blend, the model held fixed): the
held-out views must gain, nothing else may fall; ``--rule reach-guard`` asks scenes already
seen only that nothing is lost (docs/history/fill.md, "The key blend's reach and its
occlusion test", "The key blend's falloff")."""


def scene_short(synth: Path) -> str:
    """``/work/dev/et_synth`` -> ``et``."""
    return synth.name.removesuffix("_synth")


RULE_DEPTH = {"flare_gain": 0.05, "scene_loss": 0.05, "ssim_loss": 0.002, "held_loss": 0.05,
              "held_ssim_loss": 0.002}
"""``--rule depth``'s thresholds (the thirty-seventh session's rule for a depth stage
default, the model held fixed)."""


RULE_FRAMES = {"held_ssim_gain": 0.008, "held_ssim_scene_loss": 0.002, "held_loss": 0.05,
               "held_scene_loss": 0.10}
"""``--rule frames``' thresholds (the forty-fourth session's rule for the novel frames' depth,
the model held fixed, the de-flared photos unchanged)."""


RULE_SPEED = {"flare_loss": 0.05, "flare_scene_loss": 0.20, "whole_loss": 0.05,
              "ssim_loss": 0.002, "held_loss": 0.10}
"""``--rule speed``'s thresholds (the forty-eighth session's rule for a change made for speed,
which must not cost what users see: no gain asked, the losses a seed's spread allows)."""


def result_name(arm: str, scene: str, seed: int) -> str:
    return f"fmg_{arm}_fair_{scene}_s{seed}.json"


def run_arm(synth: Path, arm: str, weights: Path, seed: int, work: Path,
            holes_as_flare: bool | None = None, novel_equal_below: float | None = None,
            select_args: list[str] | None = None, mask_args: list[str] | None = None,
            finetune_args: list[str] | None = None,
            depth_args: list[str] | None = None,
            render_args: list[str] | None = None, keys: bool = False) -> Path:
    """The hand-built workspace of one arm, scored; returns the result file.
    ``mask_args`` / ``depth_args`` / ``select_args`` / ``finetune_args`` / ``render_args``:
    extra options of the mask / depth / select / finetune / both renders' stage (e.g.
    ``--crosscheck``, ``--sgm 0.1,1``, ``--max-flare 0.15``, ``--full-res-colour``,
    ``--bf16``)."""
    scene = scene_short(synth)
    ws = _copy_once(synth / "eval.ws", work / f"{scene}_{arm}_s{seed}.ws", "variants")
    steps = [["mask", str(ws), "--weights", str(weights), "--force", *(mask_args or [])],
             ["depth", str(ws), *(depth_args or [])], ["select", str(ws), *(select_args or [])],
             ["finetune", str(ws), "--preset", "quick", "--iters", "3000", "--seed", str(seed),
              *([] if holes_as_flare is None
                else ["--holes-as-flare" if holes_as_flare else "--no-holes-as-flare"]),
              *(finetune_args or [])],
             *render_steps(synth, ws, render_args or [],
                           [] if novel_equal_below is None
                           else ["--sources-equal-below", str(novel_equal_below)], keys)]
    return _run_and_score(synth, ws, steps, work / result_name(arm, scene, seed), keys)


def render_steps(synth: Path, ws: Path, render_args: list[str],
                 novel_args: list[str] | tuple = (), keys: bool = False,
                 inputs_args: list[str] | tuple = ()) -> list[list[str]]:
    """An arm's renders: the de-flared photos (with ``inputs_args`` too), then the eval's
    held-out cameras at half size (with ``novel_args`` too), and with ``keys`` the photos'
    own cameras as a novel path at half size (``keys_path_json``; with ``novel_args``); all
    with ``render_args``.
    The cameras are scored one by one, not watched: ``--source-fade 0`` (the photos' own
    cameras lie within a fade's reach of each other) and ``--path-exposure 0`` (each at its
    sources' exposure, as these renders always were)."""
    held = synth / "eval.ws" / "eval" / "heldout_cameras.json"
    steps = [["render", str(ws), "--path", "inputs", *inputs_args, *render_args],
             ["render", str(ws), "--path", str(held), "--scale", "0.5", "--source-fade", "0",
              "--path-exposure", "0", *novel_args, *render_args]]
    if keys:
        steps.append(["render", str(ws), "--path", str(keys_path_json(synth, ws)), "--scale",
                      "0.5", "--source-fade", "0", "--path-exposure", "0", *novel_args,
                      *render_args])
    return steps


KEYS_NAME = "input_cameras"
"""The photos' own cameras as a camera path: WS/eval/input_cameras.json, rendered into
WS/renders/input_cameras/ (``--keys``)."""


def keys_path_json(synth: Path, ws: Path) -> Path:
    """WS/eval/input_cameras.json: the synth scene's training cameras as a novel path, the
    keys the video passes through (a frame at each photo's position, drawn as novel frames
    are), written once."""
    from pipeline.render.frames import photos_path
    from pipeline.workspace import atomic_write_json
    from workflows.research.eval.scene import load_synth

    path = ws / "eval" / f"{KEYS_NAME}.json"
    if not path.is_file():
        scene = load_synth(synth)
        by_stem = scene.cams.by_stem()
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_json(path, photos_path([by_stem[s] for s in scene.train]))
    return path


def _copy_once(src: Path, ws: Path, *ignore: str) -> Path:
    """``src`` copied to ``ws`` (without the ``ignore`` patterns) unless ``ws`` exists: through
    a temporary folder, so an interrupted copy is never taken for a finished one."""
    if not ws.is_dir():
        tmp = ws.with_suffix(".tmp")
        shutil.rmtree(tmp, ignore_errors=True)
        shutil.copytree(src, tmp, symlinks=True, ignore=shutil.ignore_patterns(*ignore))
        tmp.rename(ws)
    return ws


def _run_and_score(synth: Path, ws: Path, steps: list[list[str]], out: Path,
                   keys: bool = False) -> Path:
    """Each of ``steps`` (``deflare-scene`` arguments) on this checkout's code, then the
    workspace scored against the synth scene as ``eval`` scores (``score_workspace.py``;
    with ``keys`` the frames at the photos' cameras too)."""
    cli = [sys.executable, "-m", "workflows.cli"]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    for step in steps:
        subprocess.run(cli + step, check=True, env=env, cwd=ROOT)
    subprocess.run([sys.executable, str(ROOT / "benchmarks" / "score_workspace.py"), str(synth),
                    str(ws), "--heldout", str(ws / "renders" / "heldout_cameras"),
                    *(["--keys", str(ws / "renders" / KEYS_NAME)] if keys else []),
                    "--out", str(out)], check=True, env=env, cwd=ROOT)
    return out


def rerender_arm(synth: Path, base_arm: str, arm: str, seed: int, work: Path,
                 depth_args: list[str], render_args: list[str] | None = None,
                 novel_args: list[str] | None = None, keys: bool = False,
                 inputs_args: list[str] | None = None) -> Path:
    """A copy of ``base_arm``'s workspace (``run``'s) with the depth stage rerun with
    ``depth_args`` (when given) and the de-flared photos and held-out cameras rendered again
    by the same model (not fine-tuned again), with ``render_args`` (``novel_args`` for the
    held-out cameras alone, ``inputs_args`` for the de-flared photos alone); scored as
    ``run`` scores. Returns the result file."""
    from pipeline.errors import UserError

    scene = scene_short(synth)
    base = work / f"{scene}_{base_arm}_s{seed}.ws"
    if not (base / "model").is_dir():
        raise UserError(f"{base}: no fine-tuned arm workspace; run the base arm first "
                        f"(python benchmarks/fmg_photo_ab.py run {synth} --arm {base_arm} "
                        f"--seed {seed} --work {work} ...)")
    ws = _copy_once(base, work / f"{scene}_{arm}_s{seed}.ws", "deflared", "renders")
    steps = [["depth", str(ws), "--force", *depth_args]] if depth_args else []
    steps += render_steps(synth, ws, render_args or [], novel_args or [], keys,
                          inputs_args or [])
    return _run_and_score(synth, ws, steps, work / result_name(arm, scene, seed), keys)


def arm_means(results: list[dict], held_ssim: bool = False, keys: bool = False) -> dict:
    """Seed means of one arm on one scene: whole, flare region, SSIM, novel views (and
    their SSIM with ``held_ssim``; with ``keys`` the frames at the photos' cameras, whole
    and inside the true flare)."""
    n = len(results)
    m = {k: sum(r["inputs"][k] for r in results) / n for k in ("psnr", "psnr_flare", "ssim")}
    m["held"] = sum(r["heldout"]["psnr"] for r in results) / n
    if held_ssim:
        m["held_ssim"] = sum(r["heldout"]["ssim"] for r in results) / n
    if keys:
        m["keys"] = sum(r["keys"]["psnr"] for r in results) / n
        m["keys_flare"] = sum(r["keys"]["psnr_flare"] for r in results) / n
    return m


PARTS = {
    "flare": {"a": [("mean", "psnr_flare", RULE["flare_gain"])],
              "b": [("scene", "psnr_flare", -RULE["flare_scene_loss"])],
              "c": [("mean", "psnr", -RULE["whole_loss"]), ("mean", "ssim", -RULE["ssim_loss"])],
              "d": [("mean", "held", -RULE["held_loss"])]},
    "novel": {"a": [("mean", "held", RULE_NOVEL["held_gain"])],
              "b": [("scene", "held", -RULE_NOVEL["held_scene_loss"])],
              "c": [("mean", "psnr_flare", -RULE_NOVEL["flare_loss"]),
                    ("mean", "psnr", -RULE_NOVEL["whole_loss"]),
                    ("mean", "ssim", -RULE_NOVEL["ssim_loss"])]},
    "depth": {"a": [("mean", "psnr_flare", RULE_DEPTH["flare_gain"]),
                    ("scene", "psnr_flare", -RULE_DEPTH["scene_loss"]),
                    ("scene", "psnr", -RULE_DEPTH["scene_loss"]),
                    ("scene", "ssim", -RULE_DEPTH["ssim_loss"])],
              "b": [("mean", "held", -RULE_DEPTH["held_loss"]),
                    ("mean", "held_ssim", -RULE_DEPTH["held_ssim_loss"])]},
    "frames": {"a": [("mean", "held_ssim", RULE_FRAMES["held_ssim_gain"]),
                     ("scene", "held_ssim", -RULE_FRAMES["held_ssim_scene_loss"])],
               "b": [("mean", "held", -RULE_FRAMES["held_loss"]),
                     ("scene", "held", -RULE_FRAMES["held_scene_loss"])]},
    "speed": {"a": [("mean", "psnr_flare", -RULE_SPEED["flare_loss"]),
                    ("scene", "psnr_flare", -RULE_SPEED["flare_scene_loss"])],
              "b": [("mean", "psnr", -RULE_SPEED["whole_loss"]),
                    ("mean", "ssim", -RULE_SPEED["ssim_loss"])],
              "c": [("mean", "held", -RULE_SPEED["held_loss"])]},
    "keys": {"a": [("mean", "keys", RULE_KEYS["keys_gain"]),
                   ("scene", "keys", -RULE_KEYS["keys_scene_loss"])],
             "b": [("mean", "keys_flare", -RULE_KEYS["keys_flare_loss"])],
             "c": [("mean", "held", -RULE_KEYS["held_loss"]),
                   ("scene", "held", -RULE_KEYS["held_scene_loss"])]},
    "keys-guard": {"a": [("mean", "keys", -RULE_KEYS["keys_scene_loss"]),
                         ("mean", "keys_flare", -RULE_KEYS["keys_flare_loss"])],
                   "b": [("mean", "held", -RULE_KEYS["held_loss"]),
                         ("scene", "held", -RULE_KEYS["held_scene_loss"])]},
    **{name: {"a": [("mean", "held", held), ("scene", "held", scene)],
              "b": [("mean", "held_ssim", -RULE_REACH["held_ssim_loss"])],
              "c": [("mean", "keys", -RULE_REACH["keys_loss"]),
                    ("mean", "keys_flare", -RULE_REACH["keys_flare_loss"])]}
       for name, held, scene in (
           ("reach", RULE_REACH["held_gain"], -RULE_REACH["held_scene_loss"]),
           ("reach-guard", -RULE_REACH["guard_held_loss"], -RULE_REACH["guard_held_scene_loss"]))},
}
"""Each rule's parts, in order: a part holds when each of its checks does, a check
(``mean``, KEY, X) when the scenes' mean difference of KEY is at least X, (``scene``, KEY, X)
when every scene's is."""


def photo_rule(candidate: dict[str, dict], baseline: dict[str, dict],
               rule: str = "flare") -> dict:
    """Per scene candidate minus baseline (``arm_means`` dicts), their mean, and each part's
    verdict (``PARTS[rule]``), in the rule's order; ``decision`` is the first failing part or
    'passes'. ``rule``: "flare" (the FMG photo rule, ``RULE``), "novel" (``RULE_NOVEL``),
    "depth" (``RULE_DEPTH``) or "frames" (``RULE_FRAMES``)."""
    diff = {s: {k: candidate[s][k] - baseline[s][k] for k in baseline[s]} for s in baseline}
    mean = {k: sum(d[k] for d in diff.values()) / len(diff)
            for k in next(iter(diff.values()))}

    def holds(where: str, key: str, least: float) -> bool:
        return (mean[key] >= least if where == "mean"
                else all(d[key] >= least for d in diff.values()))

    parts = {p: all(holds(*c) for c in checks) for p, checks in PARTS[rule].items()}
    failed = [p for p, ok in parts.items() if not ok]
    return {"per_scene": diff, "mean": mean, "parts": parts,
            "decision": f"fails ({failed[0]})" if failed else "passes"}


def arm_runs(spec: str, seeds: list[int]) -> list[tuple[str, int]]:
    """The (arm, seed) runs of an arm as ``judge`` is given it: ``NAME`` is NAME's runs on
    ``seeds``; ``NAME:2,3+OTHER:4,5`` joins the runs of arms of one setting run under
    two names (each with its own seeds; ``seeds`` is then not used)."""
    if ":" not in spec:
        return [(spec, s) for s in seeds]
    runs = []
    for part in spec.split("+"):
        name, _, text = part.partition(":")
        runs += [(name, s) for s in _seeds(text, f"arm {part!r}")]
    return runs


def judge(work: Path, candidate: str, baseline: str, scenes: list[str],
          seeds: list[int], held_baseline: dict[str, str] | None = None,
          baseline_seeds: list[int] | None = None, rule: str = "flare") -> dict:
    """The photo rule on the committed runs. ``held_baseline`` {scene: arm}: part (d)'s
    baseline on that scene (e.g. the shipped arm without the training targets the
    candidate's masks withhold, so novel views are compared like for like).
    ``baseline_seeds``: the baseline arms' seeds when not the candidate's (each arm is
    averaged over its own seeds). An arm may join the runs of two names
    (:func:`arm_runs`)."""
    from pipeline.errors import UserError

    base_seeds = seeds if baseline_seeds is None else baseline_seeds
    machines: dict[str, list[str]] = {}  # each machine the runs were made on: its runs

    def load(arm: str, scene: str, arm_seeds: list[int]) -> dict:
        files = [work / result_name(name, scene, s) for name, s in arm_runs(arm, arm_seeds)]
        missing = [str(f) for f in files if not f.is_file()]
        if missing:
            raise UserError(f"{missing[0]}: no such result; run this arm first "
                            "(python benchmarks/fmg_photo_ab.py run ...)")
        results = [json.loads(f.read_text()) for f in files]
        for f, r in zip(files, results, strict=True):
            machines.setdefault(machine_key(r), []).append(f.name)
        return arm_means(results, rule in ("depth", "frames") or rule.startswith("reach"),
                         rule.startswith(("keys", "reach")))

    cand = {s: load(candidate, s, seeds) for s in scenes}
    base = {s: load(baseline, s, base_seeds) for s in scenes}
    for scene, arm in (held_baseline or {}).items():
        if scene not in base:
            raise UserError(f"--held-baseline {scene}={arm}: {scene} is not among the scenes")
        base[scene] = {**base[scene], "held": load(arm, scene, base_seeds)["held"]}
    runs = {"candidate": arm_runs(candidate, seeds), "baseline": arm_runs(baseline, base_seeds)}
    return {"candidate": candidate, "baseline": baseline,
            "seeds": [s for _, s in runs["candidate"]], "rule": rule,
            "baseline_seeds": [s for _, s in runs["baseline"]],
            "runs": {k: [list(r) for r in v] for k, v in runs.items()},
            "held_baseline": held_baseline or {},
            "machines": {k: sorted(v) for k, v in sorted(machines.items())},
            "means": {"candidate": cand, "baseline": base}, **photo_rule(cand, base, rule)}


def machine_key(result: dict) -> str:
    """The machine a run's result file was made on, as far as it moves the numbers: the
    CPU, the platform (host kernel), torch and its threads. One machine repeats a run to
    the last digit; another moves the sample's de-flared photos by 0.16 dB
    (docs/performance.md, "The sample on another machine"), as much as a rule allows, so a
    judgement over runs of two machines says so (``judge``'s ``machines``)."""
    m = result.get("machine") or {}
    return " / ".join(str(m.get(k, "?")) for k in ("cpu", "platform", "torch", "torch_threads"))


def saved_machines(results: Path) -> dict:
    """Every saved judgement in ``results`` (a JSON file with a candidate, a baseline, seeds
    and a decision) judged again from the arm files beside it: {file: its runs' machines
    (``judge``'s ``machines``)}, and the files that cannot be judged again (an arm's runs
    missing, or no scenes named) with the reason."""
    from pipeline.errors import UserError

    judged, skipped = {}, {}
    for f in sorted(Path(results).glob("*.json")):
        try:
            d = json.loads(f.read_text())
        except (OSError, ValueError):
            continue
        if not (isinstance(d, dict) and {"candidate", "baseline", "seeds", "decision"} <= set(d)):
            continue
        scenes = list((d.get("means") or {}).get("candidate") or d.get("per_scene") or [])
        if not scenes:
            skipped[f.name] = "no scenes named"
            continue
        base = list(dict.fromkeys(d["baseline_seeds"])) if d.get("baseline_seeds") else None
        try:
            res = judge(results, d["candidate"], d["baseline"], scenes,
                        list(dict.fromkeys(d["seeds"])), d.get("held_baseline") or None,
                        base, d.get("rule", "flare"))
        except (UserError, KeyError) as e:
            skipped[f.name] = str(e)
            continue
        judged[f.name] = res["machines"]
    return {"judged": judged, "skipped": skipped,
            "mixed": sorted(k for k, v in judged.items() if len(v) > 1)}


SPREAD_KEYS = ("psnr", "psnr_flare", "ssim", "held")
"""What ``spread`` measures of each run: the de-flared photos' whole, flare region and SSIM,
the held-out views."""


def spread(work: Path, arm: str, scenes: list[str], seeds: list[int],
           per_arm: tuple[int, ...] = (2, 4)) -> dict:
    """How far one setting's runs move by chance: per scene, each of ``SPREAD_KEYS``' mean
    and standard deviation over the arm's runs (:func:`arm_runs`; at least two), and for
    two arms of that spread with ``n`` seeds each (``per_arm``) the standard error of the
    difference of their scene means' mean, sqrt(sum over scenes of 2 sd^2 / n) / scenes,
    the runs taken as independent: what ``judge``'s mean difference shows with no change
    behind it."""
    from statistics import fmean, stdev

    from pipeline.errors import UserError

    runs = arm_runs(arm, seeds)
    if len(runs) < 2:
        raise UserError(f"spread needs two or more runs of {arm!r}; give more --seeds")
    per_scene = {}
    for scene in scenes:
        files = [work / result_name(name, scene, s) for name, s in runs]
        missing = [str(f) for f in files if not f.is_file()]
        if missing:
            raise UserError(f"{missing[0]}: no such result; run this arm first "
                            "(python benchmarks/fmg_photo_ab.py run ...)")
        vals = [arm_means([json.loads(f.read_text())]) for f in files]
        per_scene[scene] = {k: {"mean": fmean(v[k] for v in vals),
                                "sd": stdev(v[k] for v in vals)}  # n - 1
                            for k in SPREAD_KEYS}
    se = {str(n): {k: (sum(2 * d[k]["sd"] ** 2 / n for d in per_scene.values()) ** 0.5
                       / len(per_scene)) for k in SPREAD_KEYS} for n in per_arm}
    return {"arm": arm, "runs": [list(r) for r in runs], "per_scene": per_scene,
            "se_mean_difference": se}


def _seeds(text: str, flag: str) -> list[int]:
    """``0,1,2`` -> [0, 1, 2]; anything else is a one-line error."""
    from pipeline.errors import UserError

    try:
        return [int(s) for s in text.split(",")]
    except ValueError:
        raise UserError(f"{flag} takes seeds separated by commas (e.g. 0,1,2), "
                        f"got {text!r}") from None


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("synth", type=Path)
    r.add_argument("--arm", required=True)
    r.add_argument("--weights", type=Path, required=True)
    r.add_argument("--seed", type=int, default=0)
    r.add_argument("--work", type=Path, required=True)
    r.add_argument("--holes-as-flare", action=argparse.BooleanOptionalAction, default=None,
                   help="the fine-tune's --[no-]holes-as-flare (default: the fine-tune's)")
    r.add_argument("--novel-equal-below", type=float, default=None,
                   help="the held-out render's --sources-equal-below (default: render's)")
    r.add_argument("--mask-args", default="",
                   help='extra options of the mask stage, e.g. --mask-args=--crosscheck (with "=": '
                        'the value starts with a dash)')
    r.add_argument("--select-args", default="",
                   help='extra options of the select stage, e.g. "--max-flare 0.15"')
    r.add_argument("--depth-args", default="",
                   help='extra options of the depth stage, e.g. "--sgm 0.1,1"')
    r.add_argument("--finetune-args", default="",
                   help="extra options of the finetune stage, e.g. "
                        "--finetune-args=--full-res-colour")
    r.add_argument("--render-args", default="",
                   help="extra options of both renders (de-flared photos, held-out cameras), "
                        "e.g. --render-args=--bf16")
    r.add_argument("--keys", action="store_true",
                   help="also render the photos' own cameras as novel frames and score them")
    rr = sub.add_parser("rerender")
    rr.add_argument("synth", type=Path)
    rr.add_argument("--from-arm", required=True)
    rr.add_argument("--arm", required=True)
    rr.add_argument("--seed", type=int, default=0)
    rr.add_argument("--work", type=Path, required=True)
    rr.add_argument("--depth-args", default="",
                    help='options of the depth stage, e.g. "--sgm 0.1,1" (none: the depth '
                         "maps are kept)")
    rr.add_argument("--render-args", default="",
                    help="options of both renders, e.g. --render-args=--bf16")
    rr.add_argument("--novel-args", default="",
                    help='options of the held-out cameras\' render alone, e.g. '
                         '"--sources-equal-below 1"')
    rr.add_argument("--inputs-args", default="",
                    help='options of the de-flared photos\' render alone, e.g. '
                         '"--n-sources 12"')
    rr.add_argument("--keys", action="store_true",
                    help="also render the photos' own cameras as novel frames and score them")
    j = sub.add_parser("judge")
    j.add_argument("work", type=Path)
    j.add_argument("--candidate", required=True)
    j.add_argument("--baseline", required=True)
    j.add_argument("--scenes", default="sceaux,et,lund")
    j.add_argument("--seeds", default="0,1")
    j.add_argument("--baseline-seeds", default=None,
                   help="the baseline arms' seeds (default: --seeds)")
    j.add_argument("--held-baseline", action="append", default=[], metavar="SCENE=ARM",
                   help="part (d)'s baseline arm on one scene (like-for-like targets)")
    j.add_argument("--rule", choices=tuple(PARTS), default="flare",
                   help="flare: the FMG photo rule; novel: a change for the novel views; "
                        "depth: a depth stage change, the model held fixed (rerender arms); "
                        "frames: a depth change for the novel frames alone (rerender arms); "
                        "speed: a change for speed that must lose nothing users see; "
                        "keys / keys-guard: a render change for the frames near the photos "
                        "(--keys arms); reach / reach-guard: the key blend's reach and "
                        "occlusion test (--keys arms)")
    j.add_argument("--out", type=Path, default=None)
    sp = sub.add_parser("spread")
    sp.add_argument("work", type=Path)
    sp.add_argument("--arm", required=True)
    sp.add_argument("--scenes", default="sceaux,et,lund")
    sp.add_argument("--seeds", default="0,1")
    sp.add_argument("--out", type=Path, default=None)
    ma = sub.add_parser("machines", help="every saved judgement in a folder judged again: "
                                          "the machines each one's runs came from")
    ma.add_argument("results", type=Path)
    ma.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    from pipeline.errors import UserError

    if a.cmd == "machines":
        if not a.results.is_dir():
            print(f"error: {a.results}: no such folder; give the folder of saved judgements "
                  "and arm results (e.g. docs/results)", file=sys.stderr)
            return 2
        res = saved_machines(a.results)
        print(f"{len(res['judged'])} judgements judged again, {len(res['skipped'])} could not "
              f"be; runs of more than one machine: {', '.join(res['mixed']) or 'none'}")
        if a.out:
            from pipeline.provenance import write_result
            write_result(a.out, res)
        return 1 if res["mixed"] else 0

    try:
        if a.cmd in ("run", "rerender"):
            if a.cmd == "run":
                if not (a.synth / "eval.ws" / "eval" / "heldout_cameras.json").is_file():
                    raise UserError(f"{a.synth}: no evaluated workspace (eval.ws); build the "
                                    "development scenes first (benchmarks/build_dev_scenes.sh)")
                if not a.weights.is_file():
                    raise UserError(f"{a.weights}: no such weights file")
                a.work.mkdir(parents=True, exist_ok=True)
            try:
                if a.cmd == "run":
                    out = run_arm(a.synth, a.arm, a.weights, a.seed, a.work, a.holes_as_flare,
                                  a.novel_equal_below, shlex.split(a.select_args),
                                  shlex.split(a.mask_args), shlex.split(a.finetune_args),
                                  shlex.split(a.depth_args), shlex.split(a.render_args),
                                  a.keys)
                else:
                    out = rerender_arm(a.synth, a.from_arm, a.arm, a.seed, a.work,
                                       shlex.split(a.depth_args), shlex.split(a.render_args),
                                       shlex.split(a.novel_args), a.keys,
                                       shlex.split(a.inputs_args))
            except subprocess.CalledProcessError as e:
                step = f"deflare-scene {e.cmd[3]}" if e.cmd[1] == "-m" else Path(e.cmd[1]).name
                raise UserError(f"{step} failed (its message is above); fix that and rerun: "
                                "finished stages are kept") from None
            print(out)
            return 0
        if a.cmd == "spread":
            res = spread(a.work, a.arm, a.scenes.split(","), _seeds(a.seeds, "--seeds"))
            for scene, d in res["per_scene"].items():
                print(f"{scene}: " + " / ".join(f"{k} {v['mean']:.3f} sd {v['sd']:.3f}"
                                                 for k, v in d.items()))
            for n, d in res["se_mean_difference"].items():
                print(f"two arms of {n} seeds, s.e. of the mean difference: "
                      + " / ".join(f"{k} {v:.3f}" for k, v in d.items()))
            if a.out:
                from pipeline.provenance import write_result
                write_result(a.out, res)
            return 0
        held = dict(x.split("=", 1) for x in a.held_baseline if "=" in x)
        if len(held) != len(a.held_baseline):
            raise UserError(f"--held-baseline takes SCENE=ARM, got {a.held_baseline}")
        res = judge(a.work, a.candidate, a.baseline, a.scenes.split(","),
                    _seeds(a.seeds, "--seeds"), held,
                    None if a.baseline_seeds is None
                    else _seeds(a.baseline_seeds, "--baseline-seeds"), a.rule)
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    for s, d in res["per_scene"].items():
        print(f"{s}: " + " / ".join(f"{k} {v:+.3f}" for k, v in d.items()))
    print("mean: " + " / ".join(f"{k} {v:+.3f}" for k, v in res["mean"].items()))
    print(f"parts {res['parts']}: {res['decision']}")
    if len(res["machines"]) > 1:
        print("warning: these runs were made on " + str(len(res["machines"])) + " machines ("
              + "; ".join(f"{k}: {len(v)} runs" for k, v in res["machines"].items())
              + "); across machines a run moves by about as much as a rule allows: run both "
              "arms on one machine", file=sys.stderr)
    if a.out:
        from pipeline.provenance import write_result
        write_result(a.out, res)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
