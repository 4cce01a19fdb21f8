"""The video's frames at the photos' own cameras against the de-flared photos, on true clean.

    python benchmarks/frames_at_photos.py WS --truth TRUTH --out JSON [--set KEY=VALUE ...]
        [--name NAME] [--sheet JPG]

The interpolate path passes through every photo's camera, so at those moments the video and
the de-flared photo show the same view. This writes a camera path with one frame at each
photo's camera (its own intrinsics and size, ``WS/<NAME>.json``), renders it as a novel
path with the render stage (its defaults, or ``--set`` render options), maps each frame into
the photo's decoded geometry and scores it, and ``WS/deflared/<stem>.png``, against
``TRUTH/clean/<stem>.png``: PSNR in the true flare region (``TRUTH/masks_gt``) and on the
whole photo, both after the per-channel gain fitted outside the flare region (the video's
exposure is the model's, the photo's its own). TRUTH is a `synth` scene or the sample's
``samples/cyprus_truth``. ``--sheet``: the photo, its frame and its de-flared photo, cut to
the flare region's box, one row per photo.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def path_file(ws, cams, name: str) -> Path:
    """WS/<name>.json: one frame at each photo's camera, named by its stem."""
    from pipeline.render.frames import photos_path

    out = ws.root / f"{name}.json"
    out.write_text(json.dumps(photos_path(cams.frames)))
    return out


def to_decoded(img: np.ndarray, frame, size: tuple[int, int]) -> np.ndarray:
    """A frame rendered at ``frame``'s pinhole camera, resampled into WS/decoded geometry."""
    import cv2

    from pipeline.camera_models import CameraModel, warp_maps
    from pipeline.render.inputs import decoded_camera

    pin = CameraModel.pinhole(frame.K, frame.width, frame.height)
    mx, my = warp_maps(pin, decoded_camera(frame, *size))
    return cv2.remap(img, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)


def gained(img: np.ndarray, ref: np.ndarray, fit: np.ndarray) -> np.ndarray:
    """``img`` times the per-channel gain fitting it to ``ref`` best on the ``fit`` pixels."""
    a, b = img[fit].astype(np.float64), ref[fit].astype(np.float64)
    g = (a * b).sum(0) / np.maximum((a * a).sum(0), 1e-12)
    return np.clip(img * g, 0, 1).astype(np.float32)


def region_psnr(img: np.ndarray, ref: np.ndarray, sel: np.ndarray) -> float | None:
    from pipeline.metrics import mse_to_psnr

    if not sel.any():
        return None
    return round(mse_to_psnr(float(np.mean((img[sel] - ref[sel]) ** 2))), 3)


def score(ws, cams, render_dir: Path, truth: Path) -> tuple[list[dict], list]:
    """Per photo: the frame's and the de-flared photo's PSNR in the flare region and whole."""
    from pipeline.images import read_image_float

    rows, tiles = [], []
    for f in cams.frames:
        clean = read_image_float(truth / "clean" / f"{f.stem}.png")
        H, W = clean.shape[:2]
        flare = read_image_float(truth / "masks_gt" / f"{f.stem}.png", size=(W, H))[..., 0] > 0.5
        photo = read_image_float(ws.decoded / f"{f.stem}.png", size=(W, H))
        frame = to_decoded(read_image_float(render_dir / f"{f.stem}.png"), f, (W, H))
        deflared = read_image_float(ws.root / "deflared" / f"{f.stem}.png", size=(W, H))
        row = {"stem": f.stem, "flare_share": round(float(flare.mean()), 5)}
        for arm, img in (("frame", frame), ("deflared", deflared), ("photo", photo)):
            g = gained(img, clean, ~flare)
            row[arm] = {"flare_psnr": region_psnr(g, clean, flare),
                        "whole_psnr": region_psnr(g, clean, np.ones_like(flare))}
        rows.append(row)
        tiles.append((photo, frame, deflared, clean, flare))
    return rows, tiles


def summary(rows: list[dict]) -> dict:
    """Over the flared photos (a clean photo's own PSNR is unbounded): each arm's mean
    flare-region and whole PSNR, and how many photos the frame beats the de-flared photo on
    in the flare region."""
    flared = [r for r in rows if r["flare_share"] > 0]
    out = {"flared_photos": len(flared),
           "frame_higher": sum(r["frame"]["flare_psnr"] > r["deflared"]["flare_psnr"]
                               for r in flared)}
    for arm in ("frame", "deflared", "photo"):
        out[arm] = {key + "_mean": round(float(np.mean([r[arm][key] for r in flared])), 3)
                    if flared else None for key in ("flare_psnr", "whole_psnr")}
    return out


def write_sheet(path: Path, tiles: list, rows: list[dict], height: int = 160) -> None:
    """Per flared photo: photo | frame | de-flared | clean, cut to the flare region's box."""
    import cv2

    from benchmarks.frames_sheet import labelled_row, stacked

    out = []
    for (photo, frame, deflared, clean, flare), r in zip(tiles, rows, strict=True):
        if not flare.any():
            continue
        ys, xs = np.nonzero(flare)
        H, W = flare.shape
        pad = max(8, round(0.1 * max(H, W)))
        y0, y1 = max(0, ys.min() - pad), min(H, ys.max() + pad + 1)
        x0, x1 = max(0, xs.min() - pad), min(W, xs.max() + pad + 1)
        cut = [np.ascontiguousarray(im[y0:y1, x0:x1]) for im in (photo, frame, deflared, clean)]
        labels = [f"{r['stem']} photo", f"frame {r['frame']['flare_psnr']}",
                  f"de-flared {r['deflared']['flare_psnr']}", "clean"]
        cells = [(np.ascontiguousarray((c[..., ::-1] * 255).round().astype(np.uint8)), lab)
                 for c, lab in zip(cut, labels, strict=True)]
        out.append(labelled_row(cells, height))
    if out:
        cv2.imwrite(str(path), stacked(out))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("workspace", type=Path)
    ap.add_argument("--truth", type=Path, required=True)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--name", default="frames_at_photos")
    ap.add_argument("--set", dest="sets", action="append", default=[],
                    metavar="KEY=VALUE", help="a render option (RenderConfig field)")
    ap.add_argument("--sheet", type=Path)
    args = ap.parse_args(argv)
    import typing
    from dataclasses import replace

    from pipeline.errors import UserError
    from pipeline.options import coerce
    from pipeline.render import RenderConfig, run
    from pipeline.workspace import Workspace
    from pipeline.ws_files import read_cameras

    for need in (args.workspace / "cameras.json", args.truth / "clean"):
        if not need.exists():
            print(f"error: {need} is missing; give a posed, fine-tuned workspace and its "
                  "truth folder", file=sys.stderr)
            return 2
    ws = Workspace(args.workspace)
    try:
        cams = read_cameras(ws)
        cfg = RenderConfig()
        hints = typing.get_type_hints(RenderConfig)
        for kv in args.sets:
            key, _, value = kv.partition("=")
            cfg = replace(cfg, **{key: coerce(value, hints[key], f"--set {kv}")})
        f = path_file(ws, cams, args.name)
        run(replace(cfg, path=str(f)), ws)
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    rows, tiles = score(ws, cams, ws.render_dir(str(f)), args.truth)
    if args.sheet:
        write_sheet(args.sheet, tiles, rows)
    from pipeline.provenance import write_result

    result = {"workspace": str(args.workspace), "truth": str(args.truth), "sets": args.sets,
              "photos": rows, "summary": summary(rows)}
    for r in rows:
        print(f"{r['stem']}: flare {r['flare_share']:.3f}, flare-region PSNR frame "
              f"{r['frame']['flare_psnr']}, de-flared {r['deflared']['flare_psnr']}, "
              f"photo {r['photo']['flare_psnr']}")
    print(json.dumps(result["summary"]))
    write_result(args.out, result)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
