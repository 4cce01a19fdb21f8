"""A posed workspace whose photos come in pairs taken from one spot, like the sample's.

    python benchmarks/twin_views.py WS --out NEW_WS [--every 2] [--keep 0.8] [--turn DEG]
    python benchmarks/twin_views.py --spacing WS [WS ...] --out JSON

The shipped sample (cyprus) holds three pairs of photos taken from one spot, turned apart
(their camera centres a few hundredths of the views' usual distance apart; docs/history/fill.md,
"Photos from one spot"); no development scene has such a pair. This writes a copy of the
posed workspace WS (its ``cameras.json``, ``WS/images`` and the decode and pose records)
where every ``--every``-th view is replaced by two views from its camera: the left and the
right ``--keep`` of its width (the other views keep their middle ``--keep``, so that all
have one size). Each is an exact pinhole photo of a camera at the same centre
and orientation, its principal point shifted: no parallax between the two, as between
photos taken from one spot. ``deflare-scene synth NEW_WS`` (or
``benchmarks/synth_like_sample.py``) then flares it like any development scene.

``--turn DEG``: the two views of a twin are turned apart instead, about the camera's own
vertical axis by -DEG/2 and +DEG/2 (the photo resampled through the rotation's homography,
bilinear), and every view is cropped to the middle rectangle both turned views fill (the
others unturned; ``--keep`` is then unused): photos from one spot looking apart, as the
sample's.

``--middle`` (with ``--turn``): each twin's photo as it is, unturned, is written too, first
(STEMm), so that a view between the two, from their spot, can be held out: with ``--every
E`` every ``E + 2``-th view is one (``synth --heldout-every E+2``). The frames of a video
between a twin's two photos look like it.

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


def view_frame(frame, tag: str, box: tuple[int, int, int, int], R: np.ndarray | None = None):
    """``frame`` as the camera of the ``box`` = (x0, y0, w, h) of its photo (its principal
    point shifted), turned by the rotation ``R`` in its own axes when given; stem STEM+tag."""
    from pipeline.camera_models import CameraModel

    x0, y0, w, h = box
    K = np.asarray(frame.K, float).copy()
    K[0, 2] -= x0
    K[1, 2] -= y0
    c2w = np.asarray(frame.c2w, float).copy()
    if R is not None:
        c2w[:3, :3] = c2w[:3, :3] @ R
    return replace(frame, stem=f"{frame.stem}{tag}", name=f"{frame.stem}{tag}.png", K=K,
                   width=w, height=h, c2w=c2w,
                   colmap_camera=CameraModel.pinhole(K, w, h).to_colmap())


def crops(frame, img: np.ndarray, keep: float, twin: bool):
    """[(Frame, image)]: with ``twin`` the left and the right ``keep`` of ``frame``'s width
    (stems STEMa, STEMb), else its middle ``keep`` (its own stem), so that every view of the
    workspace keeps one size."""
    w = int(round(keep * frame.width))
    shift = frame.width - w
    return [(view_frame(frame, tag, (x0, 0, w, frame.height)),
             np.ascontiguousarray(img[:, x0:x0 + w]))
            for tag, x0 in ((("a", 0), ("b", shift)) if twin else (("", shift // 2),))]


def yaw(deg: float) -> np.ndarray:
    """[3, 3] rotation about the camera's own y axis (down) by ``deg`` degrees."""
    t = np.radians(deg)
    return np.array([[np.cos(t), 0, np.sin(t)], [0, 1, 0], [-np.sin(t), 0, np.cos(t)]])


def turned_crop(frame, turn: float) -> tuple[int, int]:
    """(width, height) of the middle rectangle that the photo of ``frame`` fills when turned
    by -turn/2 and +turn/2 about its vertical axis (the homography K R^T K^-1 of each)."""
    K = np.asarray(frame.K, float)
    W, H = frame.width, frame.height
    ys, xs = np.mgrid[0:H, 0:W]
    pix = np.stack([xs.ravel() + 0.5, ys.ravel() + 0.5, np.ones(xs.size)])
    ok = np.ones(xs.size, bool)
    for sgn in (-1, 1):  # new pixel -> photo pixel: K R K^-1
        src = K @ yaw(sgn * turn / 2) @ np.linalg.inv(K) @ pix
        u, v = src[0] / src[2], src[1] / src[2]
        ok &= (src[2] > 0) & (u >= 1) & (u <= W - 1) & (v >= 1) & (v <= H - 1)
    ok = ok.reshape(H, W)
    cx, cy = W // 2, H // 2
    for k in range(min(cx, cy)):  # shrink a box of the photo's aspect until it is all filled
        w, h = W - 2 * int(round(k * W / H)), H - 2 * k
        x0, y0 = cx - w // 2, cy - h // 2
        if w > 0 and ok[y0:y0 + h, x0:x0 + w].all():
            return w, h
    raise ValueError(f"a turn of {turn} degrees leaves nothing of {frame.stem}")


def turned_views(frame, img: np.ndarray, turn: float, twin: bool, size: tuple[int, int],
                 middle: bool = False):
    """[(Frame, image)]: ``frame`` turned by -turn/2 and +turn/2 (stems STEMa, STEMb) with
    ``twin``, else as it is, each cropped to the middle ``size`` = (w, h); with ``middle``
    the twin's photo as it is comes first (stem STEMm): a view between the two, from their
    spot."""
    import cv2

    K = np.asarray(frame.K, float)
    w, h = size
    x0, y0 = frame.width // 2 - w // 2, frame.height // 2 - h // 2
    out = []
    tags = ((("m", 0.0),) if middle else ()) + (("a", -turn / 2), ("b", turn / 2))
    for tag, deg in (tags if twin else (("", 0.0),)):
        R = yaw(deg)
        Hm = K @ R.T @ np.linalg.inv(K)  # photo pixel -> turned pixel
        im = img if deg == 0 else cv2.warpPerspective(img, Hm, (frame.width, frame.height),
                                                      flags=cv2.INTER_LINEAR)
        out.append((view_frame(frame, tag, (x0, y0, w, h), R),
                    np.ascontiguousarray(im[y0:y0 + h, x0:x0 + w])))
    return out


def make_twins(ws_path: Path, out: Path, every: int = 2, keep: float = 0.8,
               turn: float = 0.0, middle: bool = False) -> list[str]:
    """Write the twin workspace (module docstring); returns its stems."""
    from pipeline.cameras import Cameras
    from pipeline.errors import UserError
    from pipeline.workspace import Workspace, atomic_imwrite
    from pipeline.ws_files import read_cameras, read_view_image, write_cameras

    if not 0.5 < keep < 1:
        raise UserError(f"--keep {keep}: give a share of the width between 0.5 and 1")
    if every < 1:
        raise UserError(f"--every {every}: give 1 (every view twinned) or more")
    if not 0 <= turn < 90:
        raise UserError(f"--turn {turn}: give degrees from 0 to under 90")
    if middle and turn <= 0:
        raise UserError("--middle needs --turn: the view between two turned views")
    if not (ws_path / "cameras.json").is_file():
        raise UserError(f"{ws_path}: not a posed workspace (no cameras.json); pass a workspace "
                        "after `deflare-scene pose`")
    ws = Workspace(ws_path)
    ws.require("pose")
    if out.exists():
        raise UserError(f"{out} exists; give a new folder")
    cams = read_cameras(ws)
    box = None
    if turn > 0:  # one size for all: the smallest box any camera's turned pair fills
        try:
            sizes = {turned_crop(f, turn) for f in cams.frames}
        except ValueError as e:
            raise UserError(f"--turn {turn}: {e}; give a smaller turn") from None
        box = (min(w for w, _ in sizes), min(h for _, h in sizes))
    new = Workspace(out)
    new.images.mkdir(parents=True)
    frames = []
    for i, f in enumerate(cams.frames):
        img = read_view_image(ws, f.stem, bgr=True)
        parts = (turned_views(f, img, turn, i % every == 0, box, middle) if box is not None
                 else crops(f, img, keep, i % every == 0))
        for fr, im in parts:
            atomic_imwrite(new.image_path(fr.stem), im)
            frames.append(fr)
    write_cameras(new, Cameras(frames, cams.colmap_to_world))
    manifest = json.loads((ws.root / "manifest.json").read_text())
    manifest["stages"] = {k: v for k, v in manifest["stages"].items() if k in ("decode", "pose")}
    manifest["twins"] = {"from": str(ws.root), "every": every, "keep": keep, "turn": turn,
                         "middle": middle}
    (out / "manifest.json").write_text(json.dumps(manifest, indent=2))
    return [f.stem for f in frames]


def spacing(ws_path: Path, low: float = 0.03, n: int = 4) -> dict:
    """How the posed views of ``ws_path`` are spaced: the nearest neighbour's distance
    (smallest, median), the median over the views of their median distance to the others,
    the nearest neighbour's parallax (focal length x distance x (1/near - 1/far), pixels of
    the view's image: smallest, median), the angle between each view and its nearest
    neighbour (degrees: smallest, median, largest) and the views with a neighbour among their ``n``
    nearest whose parallax is under ``low`` of the long side (a photo from about the same
    spot)."""
    from gnfr.paths import rotation_angle
    from pipeline.errors import UserError
    from pipeline.workspace import Workspace
    from pipeline.ws_files import read_cameras

    if not (ws_path / "cameras.json").is_file():
        raise UserError(f"{ws_path}: not a posed workspace (no cameras.json)")
    cams = read_cameras(Workspace(ws_path))
    c = cams.centers()
    d = np.linalg.norm(c[:, None] - c[None], axis=-1)
    np.fill_diagonal(d, np.inf)
    nn, par, med, turn, flagged = [], [], [], [], 0
    for i, f in enumerate(cams.frames):
        reach = float(f.K[0][0]) * (1.0 / f.near - 1.0 / f.far)
        order = np.argsort(d[i])[:-1]  # the view itself (inf) sorts last
        nn.append(float(d[i, order[0]]))
        par.append(nn[-1] * reach)
        turn.append(float(np.degrees(rotation_angle(
            np.asarray(f.c2w)[:3, :3], np.asarray(cams.frames[order[0]].c2w)[:3, :3]))))
        med.append(float(np.median(d[i, order])))
        flagged += int(any(d[i, j] * reach < low * max(f.width, f.height) for j in order[:n]))
    return {"views": len(nn), "width": cams.frames[0].width,
            "nearest_distance": [round(min(nn), 4), round(float(np.median(nn)), 4)],
            "median_distance": round(float(np.median(med)), 4),
            "nearest_parallax_px": [round(min(par), 1), round(float(np.median(par)), 1)],
            "nearest_turn_deg": [round(min(turn), 1), round(float(np.median(turn)), 1),
                                 round(max(turn), 1)],
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
    ap.add_argument("--turn", type=float, default=0.0,
                    help="degrees the two views of a twin look apart (0: crops, not turned)")
    ap.add_argument("--middle", action="store_true",
                    help="with --turn: each twin's photo as it is too, first (STEMm), to hold "
                         "out: `synth --heldout-every EVERY+2` holds out exactly those")
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
        stems = make_twins(a.ws[0], a.out, a.every, a.keep, a.turn, a.middle)
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(f"{a.out}: {len(stems)} views")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
