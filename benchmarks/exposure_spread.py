"""How far apart the views of a posed workspace are in exposure, measured two ways.

    python benchmarks/exposure_spread.py WS [WS ...] [--depth] [--out RESULT.json]

1. *From the pixels*: every 3D point of the COLMAP model is seen in several decoded photos.
   Its colour there (a 5x5 box mean at the keypoint, sRGB decoded to linear light; pixels
   near black or clipped left out) differs between views by the views' exposure gains
   (and, for glossy surfaces, by the view). Alternating medians solve for one log-gain per
   view and channel (the album's colour of each point, then each view's gain), the mean gain
   fixed at 1; reported in EV (stops), positive where a view is darker than the mean.
2. *From the camera*: where the photo is a JPEG with EXIF exposure time, f-number and ISO,
   the exposure each view got, log2(t * ISO / N^2), minus its mean over the views, negated
   so that it reads like (1).

Agreement of (1) with (2) says the spread is the camera's auto exposure, not noise of the
estimate. ``--depth`` measures (1) as ``finetune --exposure-match`` does instead
(``pipeline.exposure.estimate_gains``: the depth maps' warps between neighbours; a workspace
after the depth stage, no COLMAP model needed). ``--tone`` says instead how far one gain
per view is from evening the views out, against one curve per view (``finetune
--exposure-model view-curves``): each neighbour pair's shared pixels in five brightness bins
(``pipeline.exposure.pair_bins``), the views' levels in each bin, the RMS over the bins
of what the gains, the curves and one tone curve for the camera with a gain per view
(``finetune --exposure-model camera-curve``) leave between the two views, and
the RMS over the pairs of what the gains leave of each pair's median difference. Nothing is
changed in the workspace.
"""

from __future__ import annotations

import argparse
import math
import struct
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

DARK, CLIPPED = 0.01, 0.95
"""Linear values below DARK and sRGB values above CLIPPED are left out."""


def exif_exposure(path: Path) -> float | None:
    """log2(exposure time * ISO / 100 / f-number^2) from a JPEG's EXIF, or None."""
    data = path.read_bytes()[: 1 << 17]
    at = data.find(b"Exif\x00\x00")
    if at < 0:
        return None
    tiff = data[at + 6:]
    order = "<" if tiff[:2] == b"II" else ">"

    def num(fmt: str, off: int):
        return struct.unpack(order + fmt, tiff[off: off + struct.calcsize(fmt)])[0]

    def entries(off: int) -> dict[int, float]:
        out = {}
        for k in range(num("H", off)):
            e = off + 2 + 12 * k
            tag, kind = num("H", e), num("H", e + 2)
            if kind == 3:  # SHORT
                out[tag] = num("H", e + 8)
            elif kind == 4:  # LONG
                out[tag] = num("I", e + 8)
            elif kind in (5, 10):  # (S)RATIONAL, stored at an offset
                v = num("I", e + 8)
                f = "I" if kind == 5 else "i"
                out[tag] = num(f, v) / max(num(f, v + 4), 1)
        return out

    try:
        first = entries(num("I", 4))
        exif = entries(int(first[0x8769])) if 0x8769 in first else {}
    except (struct.error, KeyError, ValueError):
        return None
    t, n, iso = exif.get(0x829A), exif.get(0x829D), exif.get(0x8827) or 100
    if not t or not n:
        return None
    return math.log2(t * iso / 100.0 / n ** 2)


def track_gains(ws_path: Path, iters: int = 10) -> tuple[list[str], np.ndarray, int]:
    """(image names, [N, 3] EV per view and channel, tracks used) from the COLMAP model."""
    import cv2
    import pycolmap

    from pipeline.colour import srgb_to_linear

    rec = pycolmap.Reconstruction(str(ws_path / "colmap" / "sparse" / "0"))
    seen: dict[int, list[tuple[int, np.ndarray]]] = {}
    names = []
    for k, (_, im) in enumerate(sorted(rec.images.items())):
        names.append(im.name)
        srgb = cv2.imread(str(ws_path / "decoded" / im.name))[..., ::-1].astype(np.float32) / 255
        box = cv2.blur(srgb, (5, 5))
        lin = srgb_to_linear(box, exact=True)
        h, w = lin.shape[:2]
        for p in im.points2D:
            if not p.has_point3D():
                continue
            x, y = int(round(p.xy[0] - 0.5)), int(round(p.xy[1] - 0.5))
            if 0 <= x < w and 0 <= y < h and box[y, x].max() < CLIPPED and lin[y, x].min() > DARK:
                seen.setdefault(p.point3D_id, []).append((k, lin[y, x]))
    tracks = [t for t in seen.values() if len(t) >= 2]
    log_gain = np.zeros((len(names), 3))
    for _ in range(iters):
        residual: list[list[np.ndarray]] = [[] for _ in names]
        for t in tracks:
            views = np.array([k for k, _ in t])
            logs = np.log(np.stack([v for _, v in t]))
            albedo = np.median(logs + log_gain[views], axis=0)
            for k, v in zip(views, logs, strict=True):
                residual[k].append(albedo - v)
        log_gain = np.stack([np.median(r, axis=0) if r else np.zeros(3) for r in residual])
        log_gain -= log_gain.mean(axis=0)
    return names, log_gain / math.log(2), len(tracks)


def depth_gains(ws) -> tuple[list[str], np.ndarray, int]:
    """(names, [N, 3] EV, pairs used) as the fine-tune's ``--exposure-match`` measures them."""
    from pipeline.depth import load_views
    from pipeline.exposure import pair_differences, solve_gains
    from pipeline.ws_files import read_cameras

    cams = read_cameras(ws)
    diffs = pair_differences(load_views(ws, cams, cams.stems, with_depth=True), cams)
    gains = solve_gains(cams.stems, diffs)
    return ([f"{s}.png" for s in cams.stems],
            np.log2(np.stack([gains[s] for s in cams.stems])), len(diffs))


def tone(ws_path: Path) -> dict:
    """The pairs' brightness bins and what gains and curves leave of them (stops)."""
    from pipeline import exposure as ex
    from pipeline.depth import load_views
    from pipeline.workspace import Workspace
    from pipeline.ws_files import read_cameras

    ws = Workspace.open(ws_path)
    cams = read_cameras(ws)
    views = load_views(ws, cams, cams.stems, with_depth=True)
    bins = ex.pair_bins(views, cams)
    diffs = ex.pair_differences(views, cams)
    gains = ex.solve_gains(cams.stems, diffs)
    # how well the pairs' median differences agree with the gains solved from them: a chain
    # that drifts (each pair's estimate off the same way) would still agree; noise would not
    chain = [d - (np.log(gains[a]) - np.log(gains[b])) for a, b, d in diffs]
    curves = ex.solve_curves(cams.stems, bins)
    stops = 1.0 / math.log(2)

    camera = ex.solve_camera_curve(cams.stems, bins)

    def left(fix) -> float:
        r = [ex.corrected_level(fix[a], la) - ex.corrected_level(fix[b], lb)
             for a, b, la, lb in bins]
        return round(float(np.sqrt(np.mean(np.square(r)))) * stops, 3)

    return {
        "workspace": str(ws.root), "pairs": len(bins),
        "bins_ev": {f"{a}>{b}": [round(float(x), 3) for x in (lb - la).mean(1) * stops]
                    for a, b, la, lb in bins},
        "rms_left_ev": {"gains": left(gains), "curves": left(curves),
                        "camera_curve": left(camera)},
        "camera_curve_c": round(float(camera[cams.stems[0]][4]), 4),
        "pairs_left_by_gains_ev": round(float(np.sqrt(np.mean(np.square(chain)))) * stops, 3),
        "slopes": {s: round(float(c[3]), 3) for s, c in curves.items()},
        "spread_ev": {"gains": round(ex.spread_ev(gains), 3),
                      "curves": round(ex.spread_ev(curves), 3)},
    }


def measure(ws_path: Path, depth: bool = False) -> dict:
    from pipeline.workspace import Workspace

    ws = Workspace.open(ws_path)
    names, ev, n_tracks = depth_gains(ws) if depth else track_gains(ws.root)
    sources = ws.stage_record("decode").get("sources", {})
    photos = ws.photos_dir
    camera = {}
    for name in names:
        src = sources.get(Path(name).stem)
        if photos is not None and src and src.lower().endswith((".jpg", ".jpeg")):
            camera[name] = exif_exposure(photos / src)
    have = [n for n in names if camera.get(n) is not None]
    mean = float(np.mean([camera[n] for n in have])) if have else 0.0
    from_exif = {n: round(mean - camera[n], 3) for n in have}
    grey = ev.mean(axis=1)
    both = [(grey[names.index(n)], from_exif[n]) for n in have]
    corr = float(np.corrcoef(np.array(both).T)[0, 1]) if len(both) >= 3 and np.std(
        [b for _, b in both]) > 0 else None
    return {
        "workspace": str(ws.root), "method": "depth maps" if depth else "COLMAP tracks",
        "tracks" if not depth else "pairs": n_tracks,
        "ev_from_pixels": {n: [round(float(x), 3) for x in e] for n, e in zip(
            names, ev, strict=True)},
        "ev_from_exif": from_exif,
        "spread_ev_pixels": round(float(grey.max() - grey.min()), 3),
        "spread_ev_exif": round(max(from_exif.values()) - min(from_exif.values()), 3)
        if from_exif else None,
        "correlation": None if corr is None else round(corr, 3),
        "mean_abs_difference_ev": round(float(np.mean([abs(a - b) for a, b in both])), 3)
        if both else None,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("workspaces", type=Path, nargs="+")
    ap.add_argument("--depth", action="store_true",
                    help="gains from the depth maps, as finetune --exposure-match")
    ap.add_argument("--tone", action="store_true",
                    help="gains against curves on the pairs' brightness bins (after depth)")
    ap.add_argument("--out", type=Path)
    a = ap.parse_args()
    results = {}
    for ws in a.workspaces:
        if a.tone:
            r = results[ws.name] = tone(ws)
            print(f"{ws.name}: {r['pairs']} pairs, RMS over the bins left by gains "
                  f"{r['rms_left_ev']['gains']} EV, by curves {r['rms_left_ev']['curves']} EV, "
                  f"by one camera curve {r['rms_left_ev']['camera_curve']} EV")
            continue
        r = measure(ws, a.depth)
        results[ws.name] = r
        unit = "pairs" if a.depth else "tracks"
        print(f"{ws.name}: {r[unit]} {unit}, spread {r['spread_ev_pixels']} EV from the "
              f"pixels, {r['spread_ev_exif']} EV from EXIF, correlation {r['correlation']}, "
              f"mean |difference| {r['mean_abs_difference_ev']} EV")
    from pipeline.provenance import write_result

    write_result(a.out, {"workspaces": results})


if __name__ == "__main__":
    main()
