"""The interpolate path's zoom judged at the photos' own cameras (``render --zoom``).

    python benchmarks/path_zoom.py WS [--min-zoom 1.25] [--out JSON] [--sheet JPG]
        [--frames-sheet JPG]

An interpolate path passes through every photo's camera. There, ``--zoom fixed`` renders
the reference photo's field of view and ``--zoom photos`` the photo's own (its focal length
over its long side, ``pipeline.render.plan.photo_zoom``). For each photo this renders both
frames at its camera (two camera-path files, ``WS/path_zoom_fixed.json`` and
``WS/path_zoom_photos.json``, rendered by the render stage with its defaults into
``WS/renders/path_zoom_*``) and scores each against the photo itself, in the photo's pixels
that both frames see (the frame warped into the photo by the homography of the two
intrinsics: one camera centre): PSNR after a per-channel gain (the video's exposure is the
model's, not the photo's) and SSIM. A frame wider than the photo shows it with fewer
pixels, so the score says how much of the photo's detail the video shows as it passes.
Also per photo: its zoom, and the share of its pixels both frames see; and per setting the
default interpolate path's median and largest step (``path_steps``). ``--sheet``: per
photo, the photo and both frames warped into it; ``--frames-sheet``: the frames as the
video shows them, at the three most zoomed-in photos (photo, ``fixed``, ``photos``).

The rule (ninety-eighth session, written before the run; docs/camera_paths.md): on the
photos zoomed in at least ``--min-zoom`` from the reference, ``photos`` scores higher PSNR
than ``fixed`` on every one and by at least 1 dB on their mean; on the photos within it,
the mean PSNR falls by no more than 0.1 dB.
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

MEAN_GAIN = 1.0
"""dB the zoomed-in photos' mean PSNR must rise by (the rule)."""
OTHERS_FALL = 0.1
"""dB the other photos' mean PSNR may fall by (the rule)."""


def path_files(ws, cams, cfg) -> dict[str, Path]:
    """The two camera paths through every photo's camera: the reference photo's intrinsics
    resized as the interpolate path's (``fixed``), and those zoomed to each photo's field
    of view (``photos``); written into the workspace, one frame per photo (its stem)."""
    from gnfr.paths import PathCamera, path_to_json
    from pipeline.render.plan import base_camera, photo_zoom, zoomed

    base = base_camera(cfg, cams, "cpu")
    out = {}
    for arm, zoom in (("fixed", np.ones(len(cams.frames))), ("photos", photo_zoom(cams))):
        pcs = [PathCamera(f.stem, zoomed(base.K, float(z)), f.c2w, base.width, base.height)
               for f, z in zip(cams.frames, zoom, strict=True)]
        out[arm] = ws.root / f"path_zoom_{arm}.json"
        out[arm].write_text(json.dumps(path_to_json(pcs)))
    return out


def to_photo(frame: np.ndarray, K_frame: np.ndarray, photo_K: np.ndarray,
             size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """``frame`` [h, w, 3] warped into a photo of ``size`` (W, H) seen from the same centre
    (pixel centres at i + 0.5), and the mask of the photo's pixels the frame sees."""
    import cv2

    W, H = size
    xs, ys = np.meshgrid(np.arange(W) + 0.5, np.arange(H) + 0.5)
    ray = np.linalg.inv(photo_K) @ np.stack([xs.ravel(), ys.ravel(), np.ones(W * H)])
    uv = (K_frame @ ray)[:2] / (K_frame @ ray)[2]
    mx = (uv[0] - 0.5).reshape(H, W).astype(np.float32)
    my = (uv[1] - 0.5).reshape(H, W).astype(np.float32)
    h, w = frame.shape[:2]
    seen = (mx >= 0) & (mx <= w - 1) & (my >= 0) & (my <= h - 1)
    return cv2.remap(frame, mx, my, cv2.INTER_LINEAR), seen


def gain_psnr(img: np.ndarray, ref: np.ndarray, mask: np.ndarray) -> float:
    """PSNR of ``img`` to ``ref`` (both [H, W, 3] in [0, 1]) over ``mask`` after the
    per-channel gain that fits ``img`` to ``ref`` best there."""
    from pipeline.metrics import mse_to_psnr

    a, b = img[mask].astype(np.float64), ref[mask].astype(np.float64)
    g = (a * b).sum(0) / np.maximum((a * a).sum(0), 1e-12)
    return mse_to_psnr(float(np.mean((np.clip(a * g, 0, 1) - b) ** 2)))


def score(ws, cams, files: dict[str, Path], sheet: Path | None = None) -> list[dict]:
    """Per photo: its zoom, and each arm's PSNR / SSIM against it and share it fills."""
    from gnfr.paths import path_from_json
    from pipeline.images import read_image_float
    from pipeline.metrics import ssim
    from pipeline.render.plan import photo_zoom

    paths = {arm: {pc.name: pc for pc in path_from_json(json.loads(f.read_text()))}
             for arm, f in files.items()}
    rows, tiles = [], []
    for f, z in zip(cams.frames, photo_zoom(cams), strict=True):
        photo = read_image_float(ws.images / f"{f.stem}.png")
        warped, seen = {}, None
        for arm in files:
            pc = paths[arm][f.stem]
            img = read_image_float(ws.render_dir(str(files[arm])) / f"{f.stem}.png")
            warped[arm], s = to_photo(img, np.asarray(pc.K), np.asarray(f.K),
                                      (f.width, f.height))
            seen = s if seen is None else seen & s
        row = {"stem": f.stem, "zoom": round(float(z), 4),
               "photo_seen_share": round(float(seen.mean()), 4)}
        for arm in files:
            masked = np.where(seen[..., None], warped[arm], photo)
            row[arm] = {"psnr": round(gain_psnr(warped[arm], photo, seen), 3),
                        "ssim": round(ssim(masked, photo), 4)}
        rows.append(row)
        tiles.append([photo] + [np.where(seen[..., None], warped[a], 0) for a in files])
    if sheet:
        write_sheet(sheet, tiles, rows)
    return rows


def write_sheet(path: Path, tiles: list[list[np.ndarray]], rows: list[dict]) -> None:
    """One row per photo: the photo, the fixed frame and the zoomed frame in its pixels
    (RGB in [0, 1]), each labelled (the frames with their PSNR)."""
    import cv2

    from benchmarks.frames_sheet import labelled_row, stacked

    def bgr(img):
        return (img[..., ::-1] * 255).round().astype(np.uint8)

    out = [labelled_row(list(zip(map(bgr, tile), (f"photo zoom {row['zoom']:.2f}",
                                                  f"fixed {row['fixed']['psnr']:.2f} dB",
                                                  f"photos {row['photos']['psnr']:.2f} dB"),
                                 strict=True)), 240)
           for tile, row in zip(tiles, rows, strict=True)]
    cv2.imwrite(str(path), stacked(out), [cv2.IMWRITE_JPEG_QUALITY, 80])


def write_frames_sheet(path: Path, ws, files: dict[str, Path], rows: list[dict],
                       count: int = 3) -> None:
    """The ``count`` most zoomed-in photos, a row each: the photo, then the ``fixed`` and
    ``photos`` frames at its camera as rendered (each scaled to one height)."""
    import cv2

    from benchmarks.frames_sheet import labelled_row, stacked
    from pipeline.images import read_image

    out = [labelled_row([(read_image(ws.images / f"{row['stem']}.png", bgr=True),
                          f"photo, zoom {row['zoom']:.2f}")]
                        + [(read_image(ws.render_dir(str(files[arm])) / f"{row['stem']}.png",
                                       bgr=True), f"frame, zoom {arm}") for arm in files], 300)
           for row in sorted(rows, key=lambda r: -r["zoom"])[:count]]
    cv2.imwrite(str(path), stacked(out), [cv2.IMWRITE_JPEG_QUALITY, 80])


def path_steps(ws, cams, cfg) -> dict:
    """Per setting, the interpolate path's steps (``cfg``'s frames, paced on the depth maps'
    points): the median and largest image motion between frames as a share of the width,
    each frame in its own zoom (as the render stage's pace line measures)."""
    from pipeline.render import novel_path
    from pipeline.render.plan import scene_points, step_shares

    points = scene_points(ws, cams)
    out = {}
    for arm in ("fixed", "photos"):
        pcs = novel_path(replace(cfg, zoom=arm), cams, "cpu", points)[0]
        share = step_shares(cams, pcs, points)
        out[arm] = {"frames": len(pcs), "median_step": round(float(np.median(share)), 5),
                    "largest_step": round(float(share.max()), 5)}
    return out


def judge(rows: list[dict], min_zoom: float) -> dict:
    """The rule (module docstring) on the rows of :func:`score`."""
    zoomed = [r for r in rows if r["zoom"] >= min_zoom]
    others = [r for r in rows if r["zoom"] < min_zoom]

    def mean(rs, arm):
        return float(np.mean([r[arm]["psnr"] for r in rs])) if rs else None

    gain = mean(zoomed, "photos") - mean(zoomed, "fixed") if zoomed else None
    fall = mean(others, "fixed") - mean(others, "photos") if others else 0.0
    every = all(r["photos"]["psnr"] > r["fixed"]["psnr"] for r in zoomed)
    return {"zoomed_photos": len(zoomed), "zoomed_mean_gain_db": gain,
            "zoomed_every_higher": every, "others_mean_fall_db": fall,
            "passed": bool(zoomed) and every and gain >= MEAN_GAIN and fall <= OTHERS_FALL}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("workspace", type=Path)
    ap.add_argument("--min-zoom", type=float, default=1.25)
    ap.add_argument("--out", type=Path)
    ap.add_argument("--sheet", type=Path)
    ap.add_argument("--frames-sheet", type=Path)
    args = ap.parse_args(argv)
    from pipeline.render import RenderConfig, run
    from pipeline.workspace import Workspace
    from pipeline.ws_files import read_cameras

    if not (args.workspace / "cameras.json").is_file():
        print(f"error: {args.workspace}: no cameras.json; give a posed workspace",
              file=sys.stderr)
        return 2
    from pipeline.errors import UserError

    ws = Workspace(args.workspace)
    try:  # a workspace the render stage cannot render (no model, no views.json): one line
        cams = read_cameras(ws)
        cfg = RenderConfig(path="interpolate")
        files = path_files(ws, cams, cfg)
        for f in files.values():
            run(replace(cfg, path=str(f)), ws)
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    rows = score(ws, cams, files, args.sheet)
    if args.frames_sheet:
        write_frames_sheet(args.frames_sheet, ws, files, rows)
    from pipeline.provenance import write_result

    result = {"workspace": str(args.workspace), "min_zoom": args.min_zoom, "photos": rows,
              "judge": judge(rows, args.min_zoom), "path_steps": path_steps(ws, cams, cfg)}
    verdict = result["judge"]
    for r in rows:
        print(f"{r['stem']}: zoom {r['zoom']:.2f}, PSNR fixed {r['fixed']['psnr']:.2f} dB, "
              f"photos {r['photos']['psnr']:.2f} dB")
    print(f"rule {'passed' if verdict['passed'] else 'failed'}: {verdict}")
    write_result(args.out, result)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
