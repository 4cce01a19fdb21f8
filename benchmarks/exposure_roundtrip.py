"""What an exposure model loses by itself: each clean view to the common exposure and back.

    python benchmarks/exposure_roundtrip.py SYNTH WS [--model gain] [--model view-curves]
        [--model camera-curve] [--neighbours 4] [--deflared NAME=ARM_WS ...]
        [--out RESULT.json]

The fine-tune trains on every view brought to the views' common exposure
(``finetune --exposure-match``; ``pipeline.training_scenes.load_workspace`` through
``pipeline.exposure.apply_gain``, 8-bit, clipped), and the render stage takes the network's
colours back to each photo's own exposure by the inverse transform. Whatever the forward
transform clips cannot come back: a view whose gain or slope brightens its highlights past
white loses them in every colour the network is taught there and in every source it reads
at that exposure. This script measures that loss alone, with no network: SYNTH's clean
photos (the truth of a synth scene, ``SYNTH/clean``) taken to the common exposure by each
model's transforms, as ``estimate_gains`` solves them on WS (a workspace of that scene after
its depth stage, e.g. an ``fmg_photo_ab.py`` arm's), and back; per view, the PSNR of the
round trip against the clean photo over the whole photo and over the true flare region
(``SYNTH/masks_gt``), and the share of those pixels the forward transform clips (a channel
at 255 that was under 255).

The same file says, per view, how well each model carries a neighbour's colours into the
view (the transfer): each of the view's ``--neighbours`` nearest clean photos warped into it
by WS's depth (``pipeline.stereo.warp_sources``, where the warp holds), brought from its
exposure to the view's by the two transforms (``pipeline.exposure.between``), against the
view's clean photo, pooled over the neighbours: PSNR over the whole photo and over the true
flare region, the pixels the de-flared photo's fill takes from its neighbours.

``--deflared NAME=ARM_WS`` (repeatable) scores an arm's de-flared photos (ARM_WS/deflared,
as ``benchmarks/score_workspace.py`` does) inside the true flare region in two parts: the
pixels two or more of the view's ``--neighbours`` nearest photos reach unflared (their
warps by ARM_WS's depth hold and ARM_WS's masks leave them: where the fill may take the
photos; whether they agree there is not checked) and the rest, where the fill under the
flare layer is the network's; and split again by the arm's blend region (``input_blend`` at
the render's defaults): the pixels it leaves as photographed ("left": the mask missed them)
and the rest ("blended"). For each part it says how much of the error is a mean offset
(a cast or a wrong brightness), and for the whole region what the render would have made
with a perfect fill (the clean photo as the fill, the arm's blend region and flare layer at
the render's defaults). The file also holds, per view, the light the synthetic flare adds
outside its true mask (``flare_outside``). Nothing is written into WS or ARM_WS.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    """PSNR in dB of two uint8 arrays' pixels (inf when equal)."""
    mse = float(np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2)) / 255.0 ** 2
    return float("inf") if mse == 0 else float(-10.0 * np.log10(mse))


def round_trip(clean: np.ndarray, gain) -> tuple[np.ndarray, np.ndarray]:
    """(the view back at its own exposure, [H, W] bool: clipped on the way) for uint8 RGB
    ``clean`` through ``gain`` (a gain, curve or camera transform) and its inverse."""
    from pipeline.exposure import apply_gain, inverse

    common = apply_gain(clean, gain)
    clipped = ((common == 255) & (clean < 255)).any(axis=-1)
    return apply_gain(common, inverse(gain)), clipped


def view_row(clean: np.ndarray, region: np.ndarray, gain) -> dict:
    """The round trip's scores of one view: whole photo and the region (bool [H, W])."""
    back, clipped = round_trip(clean, gain)
    row = {"transform": [round(float(x), 5) for x in gain],
           "psnr": round(psnr(back, clean), 3),
           "clipped": round(float(clipped.mean()), 5)}
    if region.any():
        row["psnr_flare"] = round(psnr(back[region], clean[region]), 3)
        row["clipped_flare"] = round(float(clipped[region].mean()), 5)
    return row


def transfer_rows(synth: Path, ws, gains: dict, neighbours: int) -> dict:
    """{stem: {"psnr", "psnr_flare", "pixels", "pixels_flare"}}: the view's clean photo
    against its nearest clean neighbours warped into it and brought to its exposure by
    ``gains`` (pooled squared error over the neighbours' valid pixels)."""
    from pipeline.depth import load_views, nearest_views
    from pipeline.exposure import between
    from pipeline.stereo import warp_sources
    from pipeline.ws_files import read_cameras

    cams = read_cameras(ws)
    views = load_views(ws, cams, cams.stems, with_depth=True)
    clean = {s: _read_rgb(synth / "clean" / f"{s}.png") for s in views}
    for s, v in views.items():  # the truth in place of the flared photo, every pixel valid
        views[s] = replace(v, image=clean[s].astype(np.float32) / 255.0, valid=None)
    near = nearest_views(cams, neighbours)
    out = {}
    for t in sorted(views):
        vt = views[t]
        srcs = [b for b in near.get(t, []) if b in views and b in gains]
        if vt.depth is None or not srcs or t not in gains:
            continue
        w = warp_sources(vt.K, vt.c2w, vt.depth, [views[b] for b in srcs])
        region = _read_region(synth, t, vt.image.shape[:2])
        err = np.zeros(vt.depth.shape, np.float64)
        cnt = np.zeros(vt.depth.shape, np.int64)
        for k, b in enumerate(srcs):
            moved = between(w.colours[k], gains[b], gains[t])
            d = ((moved.astype(np.float64) - vt.image) ** 2).mean(-1)
            err += np.where(w.ok[k], d, 0.0)
            cnt += w.ok[k]
        row = {}
        for name, m in (("", cnt > 0), ("_flare", (cnt > 0) & region)):
            n = int(cnt[m].sum())
            row[f"pixels{name}"] = n
            if n:
                row[f"psnr{name}"] = round(float(-10 * np.log10(err[m].sum() / n)), 3)
        out[t] = row
    return out


def split_rows(synth: Path, arm, neighbours: int) -> dict:
    """{stem: {"psnr_reached", "psnr_drawn", "share_reached", "pixels", ...}} of an arm's
    de-flared photos inside the true flare region, split by whether two or more unflared
    neighbours reach a pixel and by whether the render's blend region leaves it as
    photographed ("left", "blended", "share_left"; module docstring); per part also the
    mean signed error per channel ("bias_*", sRGB 0..1: a cast or a wrong brightness) and
    the share of the squared error it explains ("bias_share_*"); pooled squared errors in
    "sq" for means."""
    from pipeline.depth import load_views, nearest_views
    from pipeline.stereo import warp_sources
    from pipeline.ws_files import read_cameras

    cams = read_cameras(arm)
    by = cams.by_stem()
    views = load_views(arm, cams, cams.stems, with_depth=True)
    near = nearest_views(cams, neighbours)
    out = {}
    for t in sorted(views):
        f = arm.deflared / f"{t}.png"
        vt = views[t]
        if not f.is_file() or vt.depth is None:
            continue
        region = _read_region(synth, t, vt.image.shape[:2])
        if not region.any():
            continue
        srcs = [b for b in near.get(t, []) if b in views]
        w = warp_sources(vt.K, vt.c2w, vt.depth, [views[b] for b in srcs])
        reached = w.ok.sum(0) >= 2
        truth = _read_rgb(synth / "clean" / f"{t}.png")
        clean = truth.astype(np.float32) / 255.0
        e = (_read_rgb(f).astype(np.float64) - truth) / 255.0
        d = (e ** 2).mean(-1)
        filled, alpha = perfect_fill(arm, by[t], clean)
        ideal = filled - clean
        left = alpha <= 0.5 / 255  # outside the render's blend region: the photo as it was
        row = {"pixels": int(region.sum()),
               "share_reached": round(float(reached[region].mean()), 4),
               "share_left": round(float(left[region].mean()), 4), "sq": {}}
        for name, err in (("region", e), ("perfect_fill", ideal)):
            row[f"psnr_{name}"] = round(float(-10 * np.log10((err[region] ** 2).mean())), 3)
            row[f"bias_{name}"] = [round(float(b), 4) for b in err[region].mean(0)]
        for name, m in (("reached", region & reached), ("drawn", region & ~reached),
                        ("left", region & left), ("blended", region & ~left)):
            n = int(m.sum())
            row["sq"][name] = [float(d[m].sum()), n]
            if n:
                row[f"psnr_{name}"] = round(float(-10 * np.log10(d[m].sum() / n)), 3)
                bias = e[m].mean(0)  # per channel: a cast or a wrong brightness
                row[f"bias_{name}"] = [round(float(b), 4) for b in bias]
                row[f"bias_share_{name}"] = round(float((bias ** 2).mean() / d[m].mean()), 4)
        out[t] = row
    return out


def perfect_fill(ws, frame, clean: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The de-flared photo [H, W, 3] (float sRGB 0..1) the render stage would make of a view
    of ``ws`` if its fill were the truth: the view's blend region and flare layer at the
    render's defaults (``pipeline.render.inputs``), ``clean`` in place of the fill; and the
    blend's alpha [H, W] (0: the photo kept as it was)."""
    from pipeline.render.config import RenderConfig
    from pipeline.render.flare_layer import apply_flare_layer
    from pipeline.render.inputs import input_blend
    from pipeline.ws_files import read_decoded

    cfg = RenderConfig()
    photo = read_decoded(ws, frame.stem)
    size = (photo.shape[1], photo.shape[0])
    alpha, _ = input_blend(frame, cfg, ws, size, size)
    out = photo.astype(np.float32) / 255.0
    a = alpha[..., None]
    filled = np.where((alpha > 0.5 / 255)[..., None], out * (1 - a) + clean * a, out)
    return apply_flare_layer(out, filled, alpha, cfg), alpha


def faint_flare(synth: Path) -> dict:
    """{stem: mean sRGB level (0..255) the synthetic flare adds outside its true mask}: light
    under the mask threshold, trained on as the scene by any fine-tune of SYNTH."""
    out = {}
    for f in sorted((synth / "clean").glob("*.png")):
        photo = synth / "photos" / f.name
        if not photo.is_file():
            continue
        d = _read_rgb(photo).astype(np.float64) - _read_rgb(f)
        outside = ~_read_region(synth, f.stem, d.shape[:2])
        out[f.stem] = round(float(d[outside].mean()), 3)
    return out


def _read_rgb(path: Path) -> np.ndarray:
    import cv2

    return cv2.cvtColor(cv2.imread(str(path), cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)


def _read_region(synth: Path, stem: str, shape) -> np.ndarray:
    import cv2

    m = cv2.imread(str(synth / "masks_gt" / f"{stem}.png"), cv2.IMREAD_GRAYSCALE)
    return np.zeros(shape, bool) if m is None else m > 127


def main(argv: list[str] | None = None) -> int:
    from pipeline.exposure import MODELS, estimate_gains
    from pipeline.provenance import write_result
    from pipeline.workspace import Workspace

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("synth", type=Path)
    ap.add_argument("ws", type=Path)
    ap.add_argument("--model", action="append", choices=list(MODELS))
    ap.add_argument("--neighbours", type=int, default=4)
    ap.add_argument("--deflared", action="append", default=[], metavar="NAME=ARM_WS")
    ap.add_argument("--out", type=Path)
    a = ap.parse_args(argv)
    ws = Workspace(a.ws)
    out: dict = {"synth": str(a.synth), "workspace": str(a.ws), "models": {}}
    for model in a.model or ["gain", "view-curves"]:
        gains = estimate_gains(ws, model=model)
        views = {}
        for stem in sorted(gains):
            f = a.synth / "clean" / f"{stem}.png"
            if not f.is_file():
                continue
            clean = _read_rgb(f)
            views[stem] = view_row(clean, _read_region(a.synth, stem, clean.shape[:2]),
                                   gains[stem])
        moved = transfer_rows(a.synth, ws, gains, a.neighbours)
        for stem, row in moved.items():
            if stem in views:
                views[stem]["transfer"] = row
        out["models"][model] = views
        print(model, " ".join(f"{s}:{r['psnr']:.1f}/{r.get('psnr_flare', float('nan')):.1f}"
                              f"/{100 * r['clipped']:.1f}%" for s, r in views.items()))
        print("  transfer", " ".join(f"{s}:{r['psnr']:.2f}/{r.get('psnr_flare', float('nan')):.2f}"
                                     for s, r in moved.items()))
    out["flare_outside"] = faint_flare(a.synth)
    for spec in a.deflared:
        name, _, path = spec.partition("=")
        if not name or not Path(path, "deflared").is_dir():
            ap.error(f"--deflared {spec}: give NAME=ARM_WS, ARM_WS a workspace with deflared/")
        rows = split_rows(a.synth, Workspace(Path(path)), a.neighbours)
        out.setdefault("deflared", {})[name] = {"workspace": path, "views": rows}
        print(name, " ".join(f"{s}:{r.get('psnr_reached', float('nan')):.2f}/"
                             f"{r.get('psnr_drawn', float('nan')):.2f}"
                             f"({100 * r['share_reached']:.0f}%)" for s, r in rows.items()))
    write_result(a.out, out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
