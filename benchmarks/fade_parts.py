"""The cross-fade's blends compared on the same renders (``render --fade-blend``).

    python benchmarks/fade_parts.py dump WS PATH.json PARTS/
    python benchmarks/fade_parts.py score WS/renders/PATH PARTS/ OUT/ --out FILE.json

``dump`` renders a camera path in this process (``--workers 1``) with today's defaults and
saves each faded frame's renders (its own, and one per other frame's sources, with their
weights) to ``PARTS/part_NNN.npz`` in the path's frame order. ``score`` rebuilds the path's
faded frames from those renders by each blend of ``pipeline.render.fade_blend.MODES``
(and ``nofade``: the frame's own render alone, as ``--source-fade 0`` renders it) into
``OUT/<blend>/`` and scores each video with ``benchmarks/video_flicker.py`` by both flows,
relative to ``mix`` (today's). One render serves every blend.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
from pathlib import Path

import numpy as np


def dump(ws: str, path: str, out: Path) -> int:
    import pipeline.render.engine as engine
    from pipeline.render import RenderConfig, run
    from pipeline.workspace import Workspace

    out.mkdir(parents=True, exist_ok=True)
    blend, count = engine.blend_renders, [0]

    def keep(own, others, mode="mix"):
        np.savez_compressed(out / f"part_{count[0]:03d}.npz", own=own,
                            others=np.stack([o for o, _ in others]),
                            weights=np.array([w for _, w in others]))
        count[0] += 1
        return blend(own, others, mode)

    engine.blend_renders = keep
    run(RenderConfig(path=path, workers=1), Workspace(ws))
    print(f"{count[0]} faded frames kept in {out}")
    return 0


def score(render: Path, parts_dir: Path, out_root: Path) -> dict:
    import cv2

    sys.path.insert(0, str(Path(__file__).parent))
    import video_flicker as vf

    from pipeline.render.fade_blend import MODES, blend_renders

    frames = json.loads((render / "cameras.json").read_text())["frames"]
    faded = [f["name"] for f in frames if f.get("fades")]
    parts = sorted(parts_dir.glob("part_*.npz"))
    if len(parts) != len(faded):
        raise SystemExit(f"{parts_dir}: {len(parts)} parts for {len(faded)} faded frames of "
                         f"{render} (dump the same path)")
    res = {}
    for name in (*MODES, "nofade"):
        d = out_root / name
        if d.exists():
            shutil.rmtree(d)
        shutil.copytree(render, d)
        for fn, p in zip(faded, parts, strict=True):
            z = np.load(p)
            others = [(o, float(w)) for o, w in zip(z["others"], z["weights"], strict=True)]
            img = z["own"] if name == "nofade" else blend_renders(z["own"], others, name)
            cv2.imwrite(str(d / f"{fn}.png"), np.ascontiguousarray(img[..., ::-1]))
        res[name] = {fl: vf.path_flicker(d, fl) for fl in vf.FLOWS}
    base = res["mix"]
    return {name: {fl: {k: r[fl][k] for k in ("mean", "max", "sharpness")}
                   | {f"{k}_rel": round(r[fl][k] / base[fl][k] - 1, 4)
                      for k in ("mean", "max", "sharpness")} for fl in r}
            for name, r in res.items()}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    d = sub.add_parser("dump")
    d.add_argument("ws"), d.add_argument("path"), d.add_argument("parts", type=Path)
    s = sub.add_parser("score")
    s.add_argument("render", type=Path), s.add_argument("parts", type=Path)
    s.add_argument("out_root", type=Path)
    s.add_argument("--out", type=Path)
    a = ap.parse_args(argv)
    if a.cmd == "dump":
        return dump(a.ws, a.path, a.parts)
    res = score(a.render, a.parts, a.out_root)
    for name, r in res.items():
        print(name, " ".join(f"{fl}: mean {v['mean_rel']:+.4f} max {v['max_rel']:+.4f} "
                             f"sharpness {v['sharpness_rel']:+.4f}" for fl, v in r.items()))
    if a.out:
        from pipeline.provenance import write_result

        write_result(a.out, {"render": str(a.render), "parts": str(a.parts), "blends": res})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
