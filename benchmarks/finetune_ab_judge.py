"""Judge a fine-tune A/B (`benchmarks/finetune_ab.py`) over scenes and seeds by a rule.

    python benchmarks/finetune_ab_judge.py RUN.json ... --arm edge_rays-0.5 --out JSON \
        [--min-region-gain 0.10] [--max-region-loss 0.20] [--max-photo-loss 0.05] \
        [--max-novel-loss 0.10] [--max-ssim-loss 0.002] [--max-slowdown 0.10]

Each RUN.json is one scene and seed, both arms (``base`` and ``--arm``). Candidate minus
base for every run, then the mean over each scene's seeds, then the mean over scenes. The
candidate passes iff

(a) the de-flared photos' flare region gains at least ``--min-region-gain`` dB on the mean;
(b) no scene's flare region loses more than ``--max-region-loss`` dB;
(c) the whole de-flared photos lose no more than ``--max-photo-loss`` dB and the held-out
    novel views no more than ``--max-novel-loss`` dB on the mean, and the SSIM of each (the
    de-flared photos' and the novel views') no more than ``--max-ssim-loss``;
(d) steps/s (each arm's fine-tune, from its own log) are no more than ``--max-slowdown``
    lower on the mean of the per-run ratios.

Runs with an arm that was interrupted and resumed are listed (``resumed_runs``): such an
arm's steps/s are of its last part alone, under that part's load.

The defaults are the edge-rays rule of `docs/presets.md` ("Edge rays, explored"). Every
scene must have the same seeds; a run file without the arm is an error.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import defaultdict
from pathlib import Path
from statistics import fmean

METRICS = {"region": "flare_region_psnr", "photo": "inputs_psnr", "photo_ssim": "inputs_ssim",
           "novel": "heldout_psnr", "novel_ssim": "heldout_ssim"}


def differences(run: dict, arm: str) -> dict:
    """Candidate minus base of one run file: each metric, and the steps/s ratio - 1."""
    a, b = run[arm], run["base"]
    d = {k: a[m] - b[m] for k, m in METRICS.items()}
    d["speed"] = a["train"]["it_per_s"] / b["train"]["it_per_s"] - 1.0
    return d


def resumed(row: dict) -> bool:
    """Whether an arm's fine-tune was interrupted and resumed (its model's provenance)."""
    trained = ((row.get("provenance") or {}).get("trained") or {})
    return bool(trained.get("resumed"))


def judge(runs: list[dict], arm: str, limits: dict) -> dict:
    """The rule's verdict with every number it read (see the module's docstring)."""
    by_scene: dict[str, dict[int, dict]] = defaultdict(dict)
    split: list[str] = []
    for run in runs:
        if arm not in run or "base" not in run:
            raise ValueError(f"{run.get('scene')}: no '{arm}' and 'base' rows")
        scene = Path(run["scene"]).name
        if "seed" not in run:
            raise ValueError(f"{scene}: the file records no seed (finetune_ab.py before --seed)")
        if run["seed"] in by_scene[scene]:
            raise ValueError(f"{scene}: seed {run['seed']} given twice")
        by_scene[scene][run["seed"]] = differences(run, arm)
        if resumed(run[arm]) or resumed(run["base"]):
            split.append(f"{scene} seed {run['seed']}")
    seeds = {s: sorted(v) for s, v in by_scene.items()}
    if len({tuple(v) for v in seeds.values()}) != 1:
        raise ValueError(f"the scenes have different seeds: {seeds}")
    keys = list(METRICS) + ["speed"]
    scene_means = {s: {k: fmean(d[k] for d in v.values()) for k in keys}
                   for s, v in sorted(by_scene.items())}
    overall = {k: fmean(m[k] for m in scene_means.values()) for k in keys}
    worst_region = min(m["region"] for m in scene_means.values())
    parts = {
        "a_region_gain": overall["region"] >= limits["min_region_gain"],
        "b_no_scene_region_loss": worst_region >= -limits["max_region_loss"],
        "c_photo": overall["photo"] >= -limits["max_photo_loss"],
        "c_novel": overall["novel"] >= -limits["max_novel_loss"],
        "c_ssim": min(overall["photo_ssim"], overall["novel_ssim"]) >= -limits["max_ssim_loss"],
        "d_speed": overall["speed"] >= -limits["max_slowdown"],
    }
    return {"arm": arm, "limits": limits, "seeds": next(iter(seeds.values())),
            "runs": {s: {str(k): d for k, d in sorted(v.items())} for s, v in by_scene.items()},
            "scene_means": scene_means, "mean": overall, "worst_scene_region": worst_region,
            "parts": parts, "passes": all(parts.values()), "resumed_runs": split}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", type=Path, nargs="+")
    ap.add_argument("--arm", required=True)
    ap.add_argument("--out", type=Path)
    for name, default in (("min-region-gain", 0.10), ("max-region-loss", 0.20),
                          ("max-photo-loss", 0.05), ("max-novel-loss", 0.10),
                          ("max-ssim-loss", 0.002), ("max-slowdown", 0.10)):
        ap.add_argument(f"--{name}", type=float, default=default)
    a = ap.parse_args()
    limits = {k: getattr(a, k) for k in ("min_region_gain", "max_region_loss", "max_photo_loss",
                                         "max_novel_loss", "max_ssim_loss", "max_slowdown")}
    runs = []
    for path in a.runs:
        try:
            runs.append(json.loads(path.read_text()))
        except (OSError, ValueError) as e:
            print(f"error: {path}: not a finetune_ab.py result file ({e})", file=sys.stderr)
            return 2
        if not isinstance(runs[-1], dict) or "scene" not in runs[-1]:
            print(f"error: {path}: not a finetune_ab.py result file (no scene)", file=sys.stderr)
            return 2
    try:
        verdict = judge(runs, a.arm, limits)
    except (ValueError, KeyError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    for scene, m in verdict["scene_means"].items():
        print(f"{scene}: flare region {m['region']:+.3f} dB, photos {m['photo']:+.3f} dB, "
              f"novel views {m['novel']:+.3f} dB, SSIM {m['photo_ssim']:+.4f} / "
              f"{m['novel_ssim']:+.4f}, steps/s {100 * m['speed']:+.1f} %")
    if verdict["resumed_runs"]:
        print("resumed (steps/s of the last part only):", ", ".join(verdict["resumed_runs"]))
    print("parts:", ", ".join(f"{k} {'yes' if v else 'NO'}" for k, v in verdict["parts"].items()))
    print("passes" if verdict["passes"] else "fails")
    if a.out:
        sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
        from pipeline.provenance import write_result

        write_result(a.out, verdict)
    return 0


if __name__ == "__main__":
    sys.exit(main())
