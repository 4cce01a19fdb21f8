"""The render tests' workspaces and helpers: a posed temple workspace with one flare square, a
textured-plane one with depth, a call counter, PSNR, a writer that dies, a path between two
photos (tests/pipeline/conftest.py makes the first two fixtures)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from pipeline.cameras import load_cameras
from pipeline.workspace import Workspace, atomic_imwrite, atomic_write_json

TINY = dict(enc_widths=(8, 8, 8), enc_blocks=(1, 1, 1), feat_ch=8, width=16, depth=1,
            heads=2, n_freqs_pts=2, n_freqs_dirs=2)


FLARED = "templeSR0002"


BOX = (slice(10, 22), slice(30, 46))  # rows, cols of the flare square in WS/images geometry


HYBRID_FLARED = "plane02"


HYBRID_BOX = (slice(40, 70), slice(60, 100))


def add_masks_views_model(ws: Workspace, flared: str, box, seed: int) -> None:
    """WS/masks (a flare square ``box`` in view ``flared``, none elsewhere), views.json and
    a tiny random GN-FR checkpoint (``seed``) at WS/model/gnfr.safetensors."""
    from gnfr.checkpoint import save_model
    from gnfr.model import GNFR, GNFRConfig
    from pipeline.select import build_views

    cams = load_cameras(ws.cameras_json)
    frac = {}
    for f in cams.frames:
        m = np.zeros((f.height, f.width), np.uint8)
        if f.stem == flared:
            m[box] = 255
        atomic_imwrite(ws.masks / f"{f.stem}.png", m)
        frac[f.stem] = float((m > 0).mean())
    atomic_write_json(ws.views_json, build_views(cams.stems, cams.centers(), frac, 0.1))
    torch.manual_seed(seed)
    save_model(ws.model_file, GNFR(GNFRConfig(**TINY)),
               {"samples": 4, "eval_views": 3, "source_scale": 0.5, "point_sampler": True})


def make_render_ws(root: Path, n_views: int = 5, seed: int = 0) -> Workspace:
    """A posed temple workspace (160x120) with views.json, masks (one small flare square in
    one view) and a tiny random GN-FR checkpoint at WS/model/gnfr.safetensors."""
    from tests.fixtures import make_temple_workspace

    ws = make_temple_workspace(root, n_views=n_views, scale=0.25)
    add_masks_views_model(ws, FLARED, BOX, seed)
    return ws


class Counter:
    """Wraps a function and counts its calls and the rays it was given."""

    def __init__(self, fn):
        self.fn, self.calls, self.rays = fn, 0, 0

    def __call__(self, *args, **kw):
        self.calls += 1
        self.rays += len(args[3]) if len(args) > 3 else 0
        return self.fn(*args, **kw)


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    mse = np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2) / 255.0**2
    return float(-10 * np.log10(max(mse, 1e-10)))


def dies_after(n: int, write_frame):
    """``write_frame`` that writes ``n`` frames, then raises KeyboardInterrupt (a kill)."""
    written = []

    def dying(path, rgb, exif=None):
        if len(written) == n:
            raise KeyboardInterrupt
        write_frame(path, rgb, exif)
        written.append(path)

    return dying


def path_between(ws, tmp_path) -> Path:
    """A camera path file of one frame halfway between plane01 and plane03."""
    from gnfr.paths import PathCamera, path_to_json

    cams = load_cameras(ws.cameras_json).by_stem()
    a, b = cams["plane01"], cams["plane03"]
    c2w = a.c2w.copy()
    c2w[:3, 3] = 0.5 * (a.c2w[:3, 3] + b.c2w[:3, 3])
    path = tmp_path / "between.json"
    atomic_write_json(path, path_to_json([PathCamera("v", a.K, c2w, a.width, a.height)]))
    return path

