"""Judge render options for hybrid novel frames (e.g. `--network-scale`) on held-out views.

The rules are docs/history/fill.md, "GN-FR's share of novel frames at a larger scale" and
"The photos' share of novel frames". For each fine-tuned workspace WS of a development scene
SYNTH, each arm (here a scale X) is rendered and scored (one thread per render, two queues
side by side), its seconds appended to a times file as ``SCENE SEED ARM SECONDS``:

    cp SYNTH/eval.ws/eval/heldout_cameras.json P/heldout_nsX.json
    OMP_NUM_THREADS=1 deflare-scene render WS --path P/heldout_nsX.json --scale 0.5 \\
        --network-scale X
    python benchmarks/score_workspace.py SYNTH WS --heldout WS/renders/heldout_nsX \\
        --out DIR/novel_nsX_SCENE_sSEED.json

then ``python benchmarks/network_scale_ab.py DIR --times TIMES --out JSON`` (X written
without its point in file names: 025, 050, 100; other arms: ``--prefix P --base B --arms
A1,A2`` read ``DIR/P{arm}_SCENE_sSEED.json``). ``--video-times FILE`` (lines as the
times file's, of each arm rendering a camera path, e.g. ``render WS --path interpolate``)
adds part (e): the video's frames at most twice the base's time too.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

BASE = "025"
RULE = {"psnr_gain": 0.10, "scene_loss": 0.20, "ssim_loss": 0.002, "time_factor": 2.0}


def read_times(path: Path) -> dict[tuple[str, int, str], float]:
    """{(scene, seed, scale): seconds} from lines ``SCENE SEED SCALE SECONDS ...``."""
    out = {}
    for line in path.read_text().splitlines():
        p = line.split()
        if len(p) >= 4:
            out[(p[0], int(p[1]), p[2])] = float(p[3])
    return out


def total_seconds(times: dict, scenes: list[str], arm: str, seeds: list[int] | None = None,
                  what: str = "times file") -> float:
    """Seconds of ``arm`` over ``scenes`` and ``seeds`` (None: the seeds the file has for
    each scene, at least one) from ``read_times``' dict; a line missing is a UserError."""
    from pipeline.errors import UserError

    values = []
    for sc in scenes:
        want = seeds if seeds is not None else [s for c, s, x in times if c == sc and x == arm]
        missing = [(sc, s, arm) for s in want if (sc, s, arm) not in times] or (
            [] if want else [(sc, "any seed", arm)])
        if missing:
            raise UserError(f"the {what} has no line for {missing[0]}")
        values += [times[(sc, s, arm)] for s in want]
    return sum(values)  # scene by scene, seed by seed: the committed judgements' order


def judge(work: Path, times: dict, scenes: list[str], seeds: list[int],
          scales: list[str], prefix: str = "novel_ns", base: str = BASE,
          video: dict | None = None) -> dict:
    """Seed means per scene and arm, each candidate's differences from ``base``, the rule's
    parts and the decision (the passing arm of larger mean PSNR gain, or none). ``video``
    ({(scene, seed, arm): seconds} of a camera path's frames, as ``read_times``): part (e),
    the arm's total at most ``time_factor`` times the base's (the forty-fifth session's
    rule: the video's own frames, not only the held-out ones)."""
    from pipeline.errors import UserError

    means: dict[str, dict] = {}
    for x in [base, *scales]:
        means[x] = {}
        for sc in scenes:
            files = [work / f"{prefix}{x}_{sc}_s{s}.json" for s in seeds]
            missing = [str(f) for f in files if not f.is_file()]
            if missing:
                raise UserError(f"{missing[0]}: no such score; render and score it first")
            held = [json.loads(f.read_text())["heldout"] for f in files]
            means[x][sc] = {k: sum(h[k] for h in held) / len(held) for k in ("psnr", "ssim")}
        means[x]["seconds"] = total_seconds(times, scenes, x, seeds)
    verdicts = {}
    for x in scales:
        diff = {sc: {k: means[x][sc][k] - means[base][sc][k] for k in ("psnr", "ssim")}
                for sc in scenes}
        mean = {k: sum(d[k] for d in diff.values()) / len(diff) for k in ("psnr", "ssim")}
        factor = means[x]["seconds"] / means[base]["seconds"]
        parts = {"a": mean["psnr"] >= RULE["psnr_gain"],
                 "b": all(d["psnr"] >= -RULE["scene_loss"] for d in diff.values()),
                 "c": mean["ssim"] >= -RULE["ssim_loss"],
                 "d": factor <= RULE["time_factor"]}
        extra = {}
        if video is not None:
            extra["video_time_factor"] = (total_seconds(video, scenes, x, what="video times file")
                                          / total_seconds(video, scenes, base,
                                                          what="video times file"))
            parts["e"] = extra["video_time_factor"] <= RULE["time_factor"]
        failed = [p for p, ok in parts.items() if not ok]
        verdicts[x] = {"per_scene": diff, "mean": mean, "time_factor": factor, **extra,
                       "parts": parts, "decision": f"fails ({failed[0]})" if failed else "passes"}
    passing = [x for x in scales if verdicts[x]["decision"] == "passes"]
    best = max(passing, key=lambda x: verdicts[x]["mean"]["psnr"]) if passing else None
    return {"rule": RULE, "scenes": scenes, "seeds": seeds, "means": means,
            "candidates": verdicts, "decision": best or "nothing changes"}


def main(argv: list[str] | None = None) -> int:
    from pipeline.errors import UserError

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("work", type=Path)
    ap.add_argument("--times", type=Path, action="append", required=True,
                    help="a times file of the renders (repeat for each queue's)")
    ap.add_argument("--scenes", default="sceaux,et,lund")
    ap.add_argument("--seeds", default="2,3,4")
    ap.add_argument("--arms", "--scales", dest="arms", default="050,100",
                    help="the candidates' labels in file names")
    ap.add_argument("--base", default=BASE, help="the baseline arm's label")
    ap.add_argument("--prefix", default="novel_ns", help="file names: PREFIX{arm}_SCENE_sSEED.json")
    ap.add_argument("--video-times", type=Path, default=None,
                    help="times of a camera path's frames per scene, seed and arm: part (e)")
    ap.add_argument("--out", type=Path)
    a = ap.parse_args(argv)
    try:
        times: dict = {}
        for t in a.times:
            if not t.is_file():
                raise UserError(f"{t}: no such times file")
            times.update(read_times(t))
        if a.video_times is not None and not a.video_times.is_file():
            raise UserError(f"{a.video_times}: no such times file")
        res = judge(a.work, times, a.scenes.split(","), [int(s) for s in a.seeds.split(",")],
                    a.arms.split(","), a.prefix, a.base,
                    read_times(a.video_times) if a.video_times else None)
    except (UserError, ValueError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    for x, v in res["candidates"].items():
        print(f"{x}: mean {v['mean']['psnr']:+.3f} dB / {v['mean']['ssim']:+.4f} SSIM, "
              f"time x{v['time_factor']:.2f}"
              + (f", video x{v['video_time_factor']:.2f}" if "video_time_factor" in v else "")
              + f": {v['decision']}")
    print(f"decision: {res['decision']}")
    if a.out:
        from pipeline.provenance import write_result
        write_result(a.out, res)
    return 0


if __name__ == "__main__":
    sys.exit(main())
