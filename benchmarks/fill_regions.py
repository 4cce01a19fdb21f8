"""Where a hybrid novel frame loses to GN-FR alone: PSNR on the photos' pixels and on GN-FR's.

    python benchmarks/fill_regions.py SYNTH:WS [SYNTH:WS ...] --hybrid heldout_cameras \\
        --hybrid-other heldout_ns100 --compare heldout_net --compare heldout_ns050 --out JSON

For each workspace WS of a development scene SYNTH, its held-out renders in
WS/renders/<folder> are scored against SYNTH/clean. A pixel is the photos' where the
``--hybrid`` render and ``--hybrid-other`` (the same hybrid fill at another
``--network-scale``) are identical: only GN-FR's pixels change with that scale. Every render
(``--hybrid``, ``--hybrid-other`` and each ``--compare``) is scored on both parts; PSNR per
view, then the mean over views and workspaces per scene (docs/history/fill.md, "GN-FR's
pixels of novel frames sampled along the whole ray").
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def _psnr(err: np.ndarray) -> float | None:
    return None if err.size == 0 else float(-10 * np.log10(max(float(err.mean()), 1e-12)))


def split_pair(pair: str) -> tuple[Path, Path]:
    """(SYNTH, WS) of a ``SYNTH:WS`` argument; a one-line UserError otherwise."""
    from pipeline.errors import UserError

    if ":" not in pair:
        raise UserError(f"{pair}: give SYNTH:WS (a development scene and a workspace)")
    synth, ws = pair.split(":", 1)
    return Path(synth), Path(ws)


def score_workspace(synth: Path, ws: Path, hybrid: str, other: str,
                    compare: list[str]) -> dict:
    """{view: {photo_share, <render>: {photo, network}}} for one workspace's held-out views."""
    import cv2

    from pipeline.errors import UserError

    renders = ws / "renders"
    folders = [hybrid, other, *compare]
    for f in folders:
        if not (renders / f).is_dir():
            raise UserError(f"{renders / f}: no such render folder; render the held-out "
                            "cameras into it first")
    out = {}
    for png in sorted((renders / hybrid).glob("*.png")):
        imgs = {}
        for f in folders:
            img = cv2.imread(str(renders / f / png.name))
            if img is None:
                raise UserError(f"{renders / f / png.name}: missing or unreadable")
            imgs[f] = img
        gt = cv2.imread(str(synth / "clean" / png.name))
        if gt is None:
            raise UserError(f"{synth / 'clean' / png.name}: no clean view to score against")
        h, w = imgs[hybrid].shape[:2]
        gt = cv2.resize(gt, (w, h), interpolation=cv2.INTER_AREA).astype(np.float64) / 255
        photo = np.all(imgs[hybrid] == imgs[other], axis=2)
        rec: dict = {"photo_share": float(photo.mean())}
        for f, img in imgs.items():
            err = ((img.astype(np.float64) / 255 - gt) ** 2).mean(axis=2)
            rec[f] = {"photo": _psnr(err[photo]), "network": _psnr(err[~photo])}
        out[png.stem] = rec
    return out


def scene_means(views: list[dict], folders: list[str]) -> dict:
    """Means over views: photo share and each render's PSNR on both parts."""
    def mean(vals):
        vals = [v for v in vals if v is not None]
        return float(np.mean(vals)) if vals else None
    return {"views": len(views), "photo_share": mean([v["photo_share"] for v in views]),
            **{f: {part: mean([v[f][part] for v in views]) for part in ("photo", "network")}
               for f in folders}}


def main(argv: list[str] | None = None) -> int:
    from pipeline.errors import UserError

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("pairs", nargs="+", help="SYNTH:WS")
    ap.add_argument("--hybrid", default="heldout_cameras")
    ap.add_argument("--hybrid-other", default="heldout_ns100")
    ap.add_argument("--compare", action="append", default=[])
    ap.add_argument("--out", type=Path)
    a = ap.parse_args(argv)
    folders = [a.hybrid, a.hybrid_other, *a.compare]
    per_ws, by_scene = {}, {}
    try:
        for pair in a.pairs:
            synth, ws = split_pair(pair)
            views = score_workspace(synth, ws, a.hybrid, a.hybrid_other, a.compare)
            per_ws[str(ws)] = views
            by_scene.setdefault(synth.name, []).extend(views.values())
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    scenes = {s: scene_means(v, folders) for s, v in by_scene.items()}
    for s, m in scenes.items():
        print(f"{s}: photo share {m['photo_share']:.2f}; " + "; ".join(
            f"{f} {m[f]['photo']:.2f} / {m[f]['network']:.2f}" for f in folders))
    if a.out:
        from pipeline.provenance import write_result
        write_result(a.out, {"folders": folders, "scenes": scenes, "workspaces": per_ws})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
