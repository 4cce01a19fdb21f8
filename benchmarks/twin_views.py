"""A posed workspace whose photos come in pairs taken from one spot, like the sample's.

    python benchmarks/twin_views.py WS --out NEW_WS [--every 2] [--keep 0.8]
    python benchmarks/twin_views.py --spacing WS [WS ...] [--out JSON]

The shipped sample (cyprus) holds three pairs of photos taken from one spot, turned apart
(their camera centres 1-3 % of the scene's camera spacing apart; docs/history/fill.md,
"Photos from one spot"); no development scene has such a pair. This writes a copy of the
posed workspace WS (its ``cameras.json``, ``WS/images`` and the decode and pose records)
where every ``--every``-th view is replaced by two views from its camera: the left and the
right ``--keep`` of its width (the other views keep their middle ``--keep``, so that all
have one size). Each is an exact pinhole photo of a camera at the same centre
and orientation, its principal point shifted: no parallax between the two, as between
photos turned apart on one spot. ``deflare-scene synth NEW_WS`` (or
``benchmarks/synth_like_sample.py``) then flares it like any development scene.

``--spacing`` reports how a posed capture is spaced instead (:func:`spacing`): how close each
view's nearest neighbour stands, against the views' usual distance, and how far it moves a
point between the view's near and far depth, the plane sweep's parallax.
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def crops(frame, keep: float, twin: bool):
    """[(Frame, column slice)]: with ``twin`` the left and the right ``keep`` of
    ``frame``'s width (stems STEMa, STEMb), else its middle ``keep`` (its own stem), so that
    every view of the workspace keeps one size."""
    w = int(round(keep * frame.width))
    shift = frame.width - w
    out = []
    for tag, x0 in ((("a", 0), ("b", shift)) if twin else (("", shift // 2),)):
        K = np.asarray(frame.K, float).copy()
        K[0, 2] -= x0
        colmap = {"model": "PINHOLE", "width": w, "height": frame.height,
                  "params": [K[0, 0], K[1, 1], K[0, 2], K[1, 2]]}
        out.append((replace(frame, stem=f"{frame.stem}{tag}", name=f"{frame.stem}{tag}.png",
                            K=K, width=w,
                            colmap_camera=colmap), slice(x0, x0 + w)))
    return out


def make_twins(ws_path: Path, out: Path, every: int = 2, keep: float = 0.8) -> list[str]:
    """Write the twin workspace (module docstring); returns its stems."""
    from pipeline.cameras import Cameras
    from pipeline.errors import UserError
    from pipeline.workspace import Workspace, atomic_imwrite
    from pipeline.ws_files import read_cameras, read_view_image, write_cameras

    if not 0.5 < keep < 1:
        raise UserError(f"--keep {keep}: give a share of the width between 0.5 and 1")
    if every < 1:
        raise UserError(f"--every {every}: give 1 (every view twinned) or more")
    if not (ws_path / "cameras.json").is_file():
        raise UserError(f"{ws_path}: not a posed workspace (no cameras.json); pass a workspace "
                        "after `deflare-scene pose`")
    ws = Workspace(ws_path)
    ws.require("pose")
    if out.exists():
        raise UserError(f"{out} exists; give a new folder")
    cams = read_cameras(ws)
    new = Workspace(out)
    new.images.mkdir(parents=True)
    frames = []
    for i, f in enumerate(cams.frames):
        img = read_view_image(ws, f.stem, bgr=True)
        parts = crops(f, keep, twin=i % every == 0)
        for fr, cols in parts:
            atomic_imwrite(new.image_path(fr.stem), np.ascontiguousarray(img[:, cols]))
            frames.append(fr)
    write_cameras(new, Cameras(frames, cams.colmap_to_world))
    manifest = json.loads((ws.root / "manifest.json").read_text())
    manifest["stages"] = {k: v for k, v in manifest["stages"].items() if k in ("decode", "pose")}
    manifest["twins"] = {"from": str(ws.root), "every": every, "keep": keep}
    (out / "manifest.json").write_text(json.dumps(manifest, indent=2))
    return [f.stem for f in frames]


def spacing(ws_path: Path, low: float = 0.03, n: int = 4) -> dict:
    """How the posed views of ``ws_path`` are spaced: the nearest neighbour's distance
    (smallest, median), the median over the views of their median distance to the others,
    the nearest neighbour's parallax (focal length x distance x (1/near - 1/far), pixels of
    the view's image: smallest, median) and the views with a neighbour among their ``n``
    nearest whose parallax is under ``low`` of the long side (a photo from about the same
    spot)."""
    from pipeline.errors import UserError
    from pipeline.workspace import Workspace
    from pipeline.ws_files import read_cameras

    if not (ws_path / "cameras.json").is_file():
        raise UserError(f"{ws_path}: not a posed workspace (no cameras.json)")
    cams = read_cameras(Workspace(ws_path))
    c = cams.centers()
    d = np.linalg.norm(c[:, None] - c[None], axis=-1)
    np.fill_diagonal(d, np.inf)
    nn, par, med, flagged = [], [], [], 0
    for i, f in enumerate(cams.frames):
        reach = float(f.K[0][0]) * (1.0 / f.near - 1.0 / f.far)
        order = np.argsort(d[i])[:-1]
        nn.append(float(d[i, order[0]]))
        par.append(nn[-1] * reach)
        med.append(float(np.median(d[i, order])))
        flagged += int(any(d[i, j] * reach < low * max(f.width, f.height) for j in order[:n]))
    return {"views": len(nn), "width": cams.frames[0].width,
            "nearest_distance": [round(min(nn), 4), round(float(np.median(nn)), 4)],
            "median_distance": round(float(np.median(med)), 4),
            "nearest_parallax_px": [round(min(par), 1), round(float(np.median(par)), 1)],
            f"views_with_a_neighbour_under_{low}": flagged}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("ws", type=Path, nargs="+")
    ap.add_argument("--out", type=Path, required=True,
                    help="the new workspace (with --spacing: the JSON written)")
    ap.add_argument("--spacing", action="store_true",
                    help="report how each WS is spaced instead of writing a workspace")
    ap.add_argument("--every", type=int, default=2)
    ap.add_argument("--keep", type=float, default=0.8)
    a = ap.parse_args(argv)
    from pipeline.errors import UserError

    try:
        if a.spacing:
            from pipeline.provenance import write_result

            rec = {str(w): spacing(w) for w in a.ws}
            for w, r in rec.items():
                print(w, r)
            write_result(a.out, {"workspaces": rec})
            return 0
        if len(a.ws) != 1:
            raise UserError("give one workspace to copy (several only with --spacing)")
        stems = make_twins(a.ws[0], a.out, a.every, a.keep)
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(f"{a.out}: {len(stems)} views")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
