"""A copy of a posed workspace with some views turned a quarter, their cameras with them.

Portrait photos among landscape ones, the cameras turned exactly: a test bed for captures of
mixed sizes.

    python -m workflows.research.turn_views WS --stems A,B --out WS_TURNED

Each named view's image, decoded photo, masks and depth maps (``depth/`` and the novel
frames' ``depth/frames/``) are turned 90 degrees clockwise
and its camera with it (``turn_frame``): the same photo, as if the camera had been held
upright. Nothing else changes, so a stage run on the copy sees the same scene with views of
two sizes. The copy leaves out what stages wrote from the images (``model/``, ``renders/``,
``deflared/``); its manifest keeps the earlier stages' records. ``WS`` is only read.
"""

from __future__ import annotations

import argparse
import shutil
from pathlib import Path

import numpy as np

from pipeline.cameras import Frame
from pipeline.errors import UserError

LEFT_OUT = ("model", "renders", "deflared")
"""What the copy leaves out: outputs made from the views as they were."""

MASK_DIRS = ("masks", "masks_fmg", "masks_ghosts")
"""Per-view mask folders turned with their views (those a workspace has)."""

# COLMAP camera models whose parameters turn by swapping: focal(s), then cx, cy, then
# radially symmetric terms that a quarter turn leaves as they are
_TURNABLE = {"SIMPLE_PINHOLE": 1, "PINHOLE": 2, "SIMPLE_RADIAL": 1, "RADIAL": 1}

QUARTER = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
"""Camera coordinates of a view turned 90 degrees clockwise: x' = -y, y' = x, z' = z."""


def turn_K(K: np.ndarray, height: int) -> np.ndarray:
    """Intrinsics of an image of ``height`` rows turned 90 degrees clockwise
    (``cv2.ROTATE_90_CLOCKWISE``): continuous pixel (u, v) goes to (height - v, u)."""
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
    return np.array([[fy, 0.0, height - cy], [0.0, fx, cx], [0.0, 0.0, 1.0]])


def turn_frame(f: Frame) -> Frame:
    """``f`` turned 90 degrees clockwise: width and height swap, the intrinsics follow
    (``turn_K``) and the camera turns about its optical axis (``QUARTER``); its centre,
    bounds and what it sees stay."""
    c2w = np.array(f.c2w, float, copy=True)
    c2w[:3, :3] = c2w[:3, :3] @ QUARTER.T
    cam = dict(f.colmap_camera)
    if cam:
        model = cam.get("model")
        if model not in _TURNABLE:
            raise UserError(f"turn_views: view {f.stem}: COLMAP model {model} cannot be turned "
                            f"here (only {', '.join(_TURNABLE)})")
        n, p = _TURNABLE[model], list(cam["params"])
        foc, (cx, cy), rest = p[:n], p[n:n + 2], p[n + 2:]
        cam = {**cam, "width": cam["height"], "height": cam["width"],
               "params": foc[::-1] + [cam["height"] - cy, cx] + rest}
    return Frame(name=f.name, stem=f.stem, K=turn_K(np.asarray(f.K, float), f.height),
                 width=f.height, height=f.width, c2w=c2w, near=f.near, far=f.far,
                 colmap_camera=cam)


def turn_workspace(src: Path, out: Path, stems: list[str]) -> list[str]:
    """Copy workspace ``src`` to ``out`` (which must not exist) with ``stems`` turned;
    returns the files turned."""
    import cv2

    from pipeline.cameras import load_cameras, save_cameras
    from pipeline.workspace import Workspace

    ws = Workspace(src)
    if not ws.cameras_json.exists():
        raise UserError(f"{ws.cameras_json} is missing: turn_views needs a posed workspace")
    if out.exists():
        raise UserError(f"{out} exists: name a new folder")
    cams = load_cameras(ws.cameras_json)
    by = cams.by_stem()
    unknown = [s for s in stems if s not in by]
    if unknown:
        raise UserError(f"turn_views: {', '.join(unknown)} not in {ws.cameras_json}")
    shutil.copytree(src, out, ignore=shutil.ignore_patterns(*LEFT_OUT))
    turned = []
    for stem in stems:
        for folder in ("images", "decoded", *MASK_DIRS):
            for p in sorted((out / folder).glob(f"{stem}.*")):
                img = cv2.imread(str(p), cv2.IMREAD_UNCHANGED)
                if img is None:
                    raise UserError(f"{p}: not a readable image")
                if not cv2.imwrite(str(p), cv2.rotate(img, cv2.ROTATE_90_CLOCKWISE)):
                    raise UserError(f"{p}: could not be written")
                turned.append(str(p.relative_to(out)))
        for dp in sorted((out / "depth").rglob(f"{stem}.npz")):  # the novel frames' too
            with np.load(dp) as d:
                arrays = {k: np.ascontiguousarray(np.rot90(d[k], -1)) for k in d.files}
            np.savez(dp, **arrays)
            turned.append(str(dp.relative_to(out)))
    cams.frames = [turn_frame(f) if f.stem in stems else f for f in cams.frames]
    save_cameras(out / ws.cameras_json.name, cams)
    return turned


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("ws", type=Path)
    ap.add_argument("--stems", required=True, help="comma-separated views to turn")
    ap.add_argument("--out", type=Path, required=True)
    a = ap.parse_args(argv)
    try:
        done = turn_workspace(a.ws, a.out, [s for s in a.stems.split(",") if s])
    except UserError as e:
        print(f"error: {e}")
        return 2
    print(f"{a.out}: {len(done)} files turned")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
