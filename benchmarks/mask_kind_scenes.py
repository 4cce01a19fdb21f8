"""Flare masks per kind of flare at the photos' scale: one-kind synthetic scenes, scored and judged.

    python benchmarks/mask_kind_scenes.py build DEV DIR [--seed 31]
        # DIR/<scene>_<kind>: `deflare-scene synth DEV/<scene>_ws --kinds KIND --heldout 2`
    python benchmarks/mask_dev_scenes.py DIR/*/ --weights A --weights B [--scales ...] --out J
    python benchmarks/mask_kind_scenes.py judge J[+J2] [J ...] --base SETTING --candidate SETTING \
        [--mean-gain G] [--scene lund] [--out K]
        # one argument per build; A+B: that build's rows from two scoring calls
    python benchmarks/mask_kind_scenes.py summary J [J ...] --setting SETTING [--out K]

`fmg eval --per-kind` scores each kind on 256 px composites whose flare is drawn for a 256 px
frame; the mask stage meets flare drawn across a whole photo (504 px here), at about twice
the pixels. This builds, for each development workspace of `benchmarks/build_dev_scenes.sh`
(``DEV/<scene>_ws``: sceaux_castle, et, lund), one synthetic-flare scene per kind of flare
(``synth --kinds KIND``, one lens and one light per scene, as `synth` draws them), to be
scored by `benchmarks/mask_dev_scenes.py` with the settings to compare. ``judge`` reads that
file: per kind, each setting's flare IoU (rays on) averaged over the scenes where the kind
marks some true pixels, the mean over kinds, and the rule of docs/history/fmg.md
("Thirty-first session: S2 judged per kind at the photos' scale"): the candidate's mean at
least 0.01 above the base's, no kind lower by more than 0.02. A setting is named
``WEIGHTS_FILE_NAME@SCALES`` (e.g. ``fmg.safetensors@1,0.75``), with ``+ghosts`` for rows
scored with `mask --ghost-lines` (``fmg.safetensors@1+ghosts``) and ``+views`` with
`--ghost-views` (rows of ``benchmarks/mask_views_scenes.py``). One build holds one lens per
kind and scene, three per kind in all, and a kind's score swings with its lenses (by 0.1-0.3
between the seeds 31 and 32): ``summary`` pools the scores of several builds (``--seed``)
for one setting, per kind the mean over every scene of every file.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

SCENES = ("sceaux", "et", "lund")
"""The development workspaces of ``benchmarks/build_dev_scenes.sh`` (``DEV/<name>_ws``)."""
MEAN_GAIN = 0.01
KIND_LOSS = 0.02
TARGET_GAIN = 0.03
"""``judge --target KIND``: the gain the change must make on its kind."""
TARGET_KIND_LOSS = 0.01
"""... while no other kind is lower by more than this and the mean over kinds is not lower
(a change aimed at one kind; docs/history/fmg.md, "Thirty-fourth session")."""


def build(dev: Path, out: Path, seed: int) -> list[Path]:
    """One `synth --kinds KIND` scene per development workspace and kind, under ``out``."""
    from pipeline.errors import UserError
    from pipeline.flare import KINDS

    missing = [dev / f"{s}_ws" for s in SCENES if not (dev / f"{s}_ws").is_dir()]
    if missing:
        raise UserError(f"{missing[0]}: no such workspace; build the development scenes first "
                        f"(bash benchmarks/build_dev_scenes.sh {dev})")
    made = []
    for scene in SCENES:
        for kind in KINDS:
            target = out / f"{scene}_{kind}"
            subprocess.run([sys.executable, "-m", "workflows.cli", "synth",
                            str(dev / f"{scene}_ws"), "--out", str(target), "--heldout", "2",
                            "--kinds", kind, "--seed", str(seed)], check=True, cwd=ROOT)
            made.append(target)
    return made


def setting(row: dict) -> str:
    """``WEIGHTS_FILE_NAME@SCALES`` of a mask_dev_scenes.py (or mask_views_scenes.py) row,
    ``+ghosts`` added for a row scored with `mask --ghost-lines`, ``+views`` with
    `--ghost-views`, ``+raysMIN,OPP`` with a ray rule of its own (mask_dev_scenes.py
    ``--ray-rule``), ``+lines`` with the streak lines (``--streak-lines``), ``+cores`` with
    lamps found by their core (``--light-cores``), ``+holes`` with the enclosed holes
    filled (``--fill-holes``), ``+pads=MODES``
    with `mask --pads` (``--pads``), then ``+regions`` with `--pads-keep regions`."""
    scales = ",".join(f"{s:g}" for s in row.get("scales", [1.0]))
    rule = row.get("ray_rule")
    return (f"{Path(row['weights']).name}@{scales}{'+ghosts' if row.get('ghost_lines') else ''}"
            f"{'+views' if row.get('ghost_views') else ''}"
            f"{'' if rule is None else f'+rays{rule[0]},{rule[1]:g}'}"
            f"{'+lines' if row.get('streak_lines') else ''}"
            f"{'+cores' if row.get('light_cores') else ''}"
            f"{'+holes' if row.get('fill_holes') else ''}"
            f"{'+pads=' + ','.join(row['pads']) if row.get('pads') else ''}"
            f"{'+regions' if row.get('pads_keep') == 'regions' else ''}")


def kind_scores(rows: list[dict], kind: str, name: str, scene: str | None = None
                ) -> dict[str, float]:
    """{scene: flare IoU} of setting ``name`` (rays on) on the scenes of ``kind`` whose truth
    has flare pixels (with ``scene``, only that workspace's: ``<scene>_<kind>``)."""
    return {r["scene"]: r["flare_iou"] for r in rows if r["rays"] and setting(r) == name
            and r["scene"].endswith("_" + kind) and r["truth_share"] > 0
            and (scene is None or r["scene"] == f"{scene}_{kind}")}


def judge(files: list[list[dict]], base: str, candidate: str, target: str | None = None,
          mean_gain: float = MEAN_GAIN, scene: str | None = None,
          target_gain: float = TARGET_GAIN) -> dict:
    """Per kind: each setting's flare IoU (rays on) averaged over the scenes whose truth
    has flare pixels, pooled over the builds (``files``: each build's rows, both settings
    scored on the same scenes; ``scene``: one workspace's scenes only); the means over
    kinds and the rule's verdict: the mean's gain (``mean_gain``, a rule's own, default
    MEAN_GAIN) and worst kind (KIND_LOSS), or for a change aimed at the kind ``target``,
    its gain (``target_gain``, default TARGET_GAIN), the other kinds (TARGET_KIND_LOSS) and
    the mean."""
    from pipeline.errors import UserError
    from pipeline.flare import KINDS

    for i, rows in enumerate(files):
        found = sorted({setting(r) for r in rows if r["rays"]})
        for name in (base, candidate):
            if name not in found:
                raise UserError(f"{name}: no such setting in scores file {i + 1}; it has "
                                f"{', '.join(found)}")
    kinds = {}
    for kind in KINDS:
        per = {name: [kind_scores(rows, kind, name, scene) for rows in files]
               for name in (base, candidate)}
        scenes = [(i, s) for i, f in enumerate(per[base]) for s in sorted(f)]
        lacking = [(i, s) for i, s in scenes if s not in per[candidate][i]]
        if lacking:
            i, s = lacking[0]
            raise UserError(f"{candidate}: scene {s} of build {i + 1} not scored; score it "
                            "on every scene of the base's build")
        if scenes:
            kinds[kind] = {"scenes": [s for _, s in scenes],
                           **{n: sum(v[i][s] for i, s in scenes) / len(scenes)
                              for n, v in per.items()}}
    if not kinds:
        raise UserError(f"no scene named {scene or '<scene>'}_<kind> with true flare in the "
                        "files: score the scenes that `build` writes")
    mean = {n: sum(k[n] for k in kinds.values()) / len(kinds) for n in (base, candidate)}
    worst = min(k[candidate] - k[base] for k in kinds.values())
    passes = mean[candidate] - mean[base] >= mean_gain and worst >= -KIND_LOSS
    rule = {"mean_gain": mean_gain, "kind_loss": KIND_LOSS, "scene": scene}
    if target is not None:
        if target not in kinds:
            raise UserError(f"--target {target}: no scored scene of that kind; the files have "
                            f"{', '.join(kinds)}")
        gain = kinds[target][candidate] - kinds[target][base]
        worst = min(k[candidate] - k[base] for n, k in kinds.items() if n != target)
        passes = (gain >= target_gain and worst >= -TARGET_KIND_LOSS
                  and mean[candidate] >= mean[base])
        rule = {"target": target, "target_gain": target_gain,
                "other_kind_loss": TARGET_KIND_LOSS, "mean_not_lower": True}
    return {"base": base, "candidate": candidate, "kinds": kinds, "mean": mean,
            "mean_gain": mean[candidate] - mean[base], "worst_kind_change": worst,
            "rule": rule, "passes": passes}


def summary(files: list[list[dict]], name: str) -> dict:
    """Per kind: ``name``'s flare IoU (rays on) over every scene of every file whose truth
    has flare pixels (mean, count, and each file's own mean); the mean over kinds."""
    from pipeline.errors import UserError
    from pipeline.flare import KINDS

    kinds = {}
    for kind in KINDS:
        per_file = [list(kind_scores(rows, kind, name).values()) for rows in files]
        every = [v for f in per_file for v in f]
        if every:
            kinds[kind] = {"mean": sum(every) / len(every), "scenes": len(every),
                           "per_file": [sum(f) / len(f) if f else None for f in per_file]}
    if not kinds:
        raise UserError(f"{name}: no scored one-kind scene of this setting in the files")
    return {"setting": name, "kinds": kinds,
            "mean": sum(k["mean"] for k in kinds.values()) / len(kinds)}


def read_rows(path: Path) -> list[dict]:
    """The rows of a ``benchmarks/mask_dev_scenes.py`` results file."""
    from pipeline.errors import UserError

    if not path.is_file():
        raise UserError(f"{path}: no such file; score the scenes with "
                        "benchmarks/mask_dev_scenes.py --out first")
    try:
        return json.loads(path.read_text())["rows"]
    except (ValueError, KeyError, TypeError):
        raise UserError(f"{path}: not a results file of benchmarks/mask_dev_scenes.py (JSON "
                        "with rows); pass the file its --out wrote") from None


def build_rows(spec: str) -> list[dict]:
    """The rows of one build: ``FILE`` or ``FILE+FILE...`` (settings of the same build scored
    in separate calls, e.g. the base's committed file and a candidate's new one)."""
    return [r for part in spec.split("+") for r in read_rows(Path(part))]


def print_judgement(res: dict) -> None:
    base, cand = res["base"], res["candidate"]
    for kind, k in res["kinds"].items():
        print(f"{kind:>9}: {k[base]:.3f} -> {k[cand]:.3f} ({len(k['scenes'])} scenes)")
    print(f"mean: {res['mean'][base]:.4f} -> {res['mean'][cand]:.4f} "
          f"({res['mean_gain']:+.4f}; worst "
          f"{'other ' if 'target' in res['rule'] else ''}kind {res['worst_kind_change']:+.4f}): "
          f"{'passes' if res['passes'] else 'fails'}")


def print_summary(res: dict) -> None:
    for kind, k in res["kinds"].items():
        files = ", ".join("-" if v is None else f"{v:.3f}" for v in k["per_file"])
        print(f"{kind:>9}: {k['mean']:.3f} over {k['scenes']} scenes (per file {files})")
    print(f"mean over kinds: {res['mean']:.4f}")


def main(argv: list[str] | None = None) -> int:
    from pipeline.errors import UserError

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    b = sub.add_parser("build")
    b.add_argument("dev", type=Path)
    b.add_argument("out", type=Path)
    b.add_argument("--seed", type=int, default=31)
    j = sub.add_parser("judge")
    j.add_argument("scores", nargs="+")
    j.add_argument("--base", required=True)
    j.add_argument("--candidate", required=True)
    j.add_argument("--target", default=None, metavar="KIND",
                   help="judge a change aimed at one kind (its gain, the others, the mean)")
    j.add_argument("--target-gain", type=float, default=TARGET_GAIN,
                   help=f"with --target: the gain on that kind a rule asks (default "
                        f"{TARGET_GAIN})")
    j.add_argument("--mean-gain", type=float, default=MEAN_GAIN,
                   help=f"the gain of the mean over kinds a rule asks (default {MEAN_GAIN})")
    j.add_argument("--scene", default=None,
                   help="judge one workspace's scenes only (sceaux, et or lund)")
    j.add_argument("--out", type=Path)
    s = sub.add_parser("summary")
    s.add_argument("scores", type=Path, nargs="+")
    s.add_argument("--setting", required=True)
    s.add_argument("--out", type=Path)
    a = ap.parse_args(argv)
    try:
        if a.cmd == "build":
            for p in build(a.dev, a.out, a.seed):
                print(p)
            return 0
        if a.cmd == "judge":
            res = judge([build_rows(str(f)) for f in a.scores], a.base, a.candidate,
                        a.target, a.mean_gain, a.scene, a.target_gain)
            print_judgement(res)
        else:
            res = summary([read_rows(f) for f in a.scores], a.setting)
            print_summary(res)
        scores = [str(f) for f in a.scores]
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    if a.out:
        from pipeline.provenance import write_result
        write_result(a.out, {"scores": scores, **res})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
