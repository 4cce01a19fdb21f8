"""A small learned fusion of the mask stage's evidence, scored on a development scene it never saw.

    python benchmarks/mask_fusion.py features BUILD/SCENE_KIND [...] [--posed WS ...] --work DIR
    python benchmarks/mask_fusion.py folds DIR [--fit-seeds 0,1] [--out J]

Issue 10 item 4 allows the evidence across views to be fused with the FMG's probabilities
"by a documented rule or a small learned fusion". The rules are in the product (the ghost
lines the other photos confirm, `mask --crosscheck`); this tries the learned one. For every
view of each synthetic-flare scene (``synth`` folders, posed with their true cameras in
``DIR``, the mask stage run there with its defaults) ``features`` keeps per pixel
(``FEATURES``): the FMG's logit, its probability max-filtered over 5 px and blurred at two
widths, the flare rays, the ghost-line candidates, whether the neighbouring photos judge the
pixel and by how much the view is brighter than their consensus (``pipeline.crosscheck``),
the luminance, the saturation, the distance to the nearest light, and the stage's own mask;
the true mask beside them. ``--posed WS``: a clean posed workspace (every mark false).

``folds`` fits a per-pixel network (``fit``: two hidden layers of 32, binary
cross-entropy, the true flare and a sample of the rest re-weighted to the view's counts) on
the scenes of two development workspaces and scores the third (leave one scene out: the
builds' folders are named ``<build>_<scene>_<kind>``), with the cut that does best on the
training scenes; once with every feature and once without the two of the other photos
(``CROSS_VIEW``). Per held-out scene and fit seed: each kind's flare IoU (pooled over a
scene's views, averaged over its scenes as ``mask_kind_scenes.py`` pools them) for the
stage's mask and the fusion's, and the share the fusion marks of the clean workspace of that
scene (``<scene>_ws_posed``). An exploration: it decides nothing.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

FEATURES = ("logit", "p_max5", "p_blur7", "rays", "ghost_candidate", "judged", "excess",
            "log_luminance", "saturation", "light_distance", "stage_mask", "p_blur20")
"""The per-pixel features, in the order ``features`` stores them."""
CROSS_VIEW = ("judged", "excess")
"""The features that need the other photos (set to 0 for the fits without them)."""
CUTS = (0.3, 0.4, 0.5, 0.6, 0.7, 0.8)
"""The fusion's cuts tried on the training scenes."""
NEGATIVES = 20000
"""Pixels without flare sampled per training view (all its flare pixels are kept)."""
STEPS = 3000
"""Adam steps of a fit (batches of 8 192 pixels, rate 3e-3)."""


def view_features(ws, base: dict, consensus: dict, model, cfg, stem: str) -> np.ndarray:
    """[len(FEATURES), H, W] float16 features of one view (module docstring)."""
    import cv2
    import torch

    from pipeline import mask
    from pipeline.crosscheck import CrosscheckRule, excess_over_consensus
    from pipeline.ws_files import read_mask_file, read_view_image

    img = read_view_image(ws, stem, bgr=True)
    with torch.inference_mode():
        p = mask.fmg_probs(model, [img], cfg.work_size)[0]
    found = mask.lights_at_work_size(img, cfg.work_size)
    rays = mask.ray_marks(img, cfg.work_size, mask.ray_config(cfg), found)
    gpath = ws.root / mask.GHOST_CANDIDATES_DIR / f"{stem}.png"
    h, w = p.shape
    ghosts = read_mask_file(gpath, size=(w, h)) if gpath.is_file() else np.zeros((h, w), bool)
    rule = CrosscheckRule()
    c = consensus[stem]
    judged, excess, thr = excess_over_consensus(c, rule.min_support, rule.abs_threshold,
                                                rule.rel_threshold, rule.slack)
    q = np.clip(p, 1e-4, 1 - 1e-4)
    rgb = img[..., ::-1].astype(np.float32) / 255
    hi = rgb.max(-1)
    _, scale, lights = found
    yy, xx = np.mgrid[0:h, 0:w]
    dist = np.ones((h, w), np.float32)
    for x, y, _r in lights:
        dist = np.minimum(dist, np.hypot(xx - x / scale, yy - y / scale) / np.hypot(h, w))
    return np.stack([
        np.log(q / (1 - q)), cv2.dilate(p, np.ones((5, 5), np.uint8)),
        cv2.GaussianBlur(p, (0, 0), 7), rays, ghosts, judged,
        np.where(judged, np.clip(excess / thr, -3, 10), 0), np.log(c.lum_view + 1e-3),
        (hi - rgb.min(-1)) / (hi + 1e-3), dist, base[stem], cv2.GaussianBlur(p, (0, 0), 20),
    ]).astype(np.float16)


def workspace_features(ws, truth_of, out: Path) -> None:
    """Run the mask stage (its defaults) in ``ws`` and write OUT/<stem>.npz for every view:
    ``feats`` (``view_features``), ``truth`` (``truth_of(stem, (w, h))``), ``base`` (the
    stage's mask)."""
    from pipeline import mask
    from pipeline.crosscheck import view_consensus
    from pipeline.ws_files import read_cameras, read_mask

    cfg = mask.MaskConfig()
    mask.run(cfg, ws)
    stems = read_cameras(ws).stems
    base = {s: read_mask(ws, s) for s in stems}
    model = mask.load_fmg_weights(mask.weights_path(cfg))
    consensus = dict(view_consensus(ws, base, label="fusion: the other photos"))
    out.mkdir(parents=True, exist_ok=True)
    for s in stems:
        f = view_features(ws, base, consensus, model, cfg, s)
        np.savez_compressed(out / f"{s}.npz", feats=f, truth=truth_of(s, base[s].shape[::-1]),
                            base=base[s])


def features(synths: list[Path], posed: list[Path], work: Path) -> None:
    """``features``: each synth folder posed in WORK (as `mask_views_scenes.py` poses it) and
    each clean workspace shared there; features under WORK/feats/<name>."""
    from pipeline.workspace import Workspace
    from pipeline.ws_files import read_mask_file
    from workflows.research.eval.scene import load_synth
    from workflows.research.eval.workspaces import build_workspace, shared_workspace

    for src in posed:
        ws = shared_workspace(Workspace(src), work / f"{src.name}_posed.ws")
        workspace_features(ws, lambda s, wh: np.zeros(wh[::-1], bool),
                           work / "feats" / f"{src.name}_posed")
        print(f"features: {src}", flush=True)
    for synth in synths:
        name = f"{synth.parent.name}_{synth.name}"
        ws = build_workspace(load_synth(synth), work / f"{name}.ws")
        workspace_features(
            ws, lambda s, wh, synth=synth: read_mask_file(synth / "masks_gt" / f"{s}.png", size=wh),
            work / "feats" / name)
        print(f"features: {synth}", flush=True)


def load_views(folder: Path) -> list[dict]:
    """The views of one feature folder, features as float32 (the logit held to +-9)."""
    views = []
    for f in sorted(folder.glob("*.npz")):
        d = dict(np.load(f))
        x = d["feats"].astype(np.float32)
        x[0] = np.clip(x[0], -9, 9)
        views.append({"x": x, "truth": d["truth"], "base": d["base"]})
    return views


def kept(drop: tuple[str, ...]) -> np.ndarray:
    """[F] float32: 0 for the features of ``drop`` (left out of a fit), 1 for the others."""
    return np.array([name not in drop for name in FEATURES], np.float32)


def training_pixels(scenes: list[list[dict]], rng, keep: np.ndarray
                    ) -> tuple[np.ndarray, ...]:
    """(X [N, F], y [N], weight [N]): every flare pixel of every view and ``NEGATIVES`` others,
    each weighted by how many of the view's non-flare pixels it stands for; features times
    ``keep`` (``kept``)."""
    xs, ys, ws = [], [], []
    for views in scenes:
        for v in views:
            x = v["x"].reshape(len(FEATURES), -1)
            t = v["truth"].ravel()
            pos, neg = np.nonzero(t)[0], np.nonzero(~t)[0]
            k = min(NEGATIVES, len(neg))
            idx = np.concatenate([pos, rng.choice(neg, k, replace=False)])
            xs.append(x[:, idx].T * keep)
            ys.append(t[idx])
            ws.append(np.concatenate([np.ones(len(pos)), np.full(k, len(neg) / max(k, 1))]))
    return (np.concatenate(xs), np.concatenate(ys).astype(np.float32),
            np.concatenate(ws).astype(np.float32))


def fit(x: np.ndarray, y: np.ndarray, w: np.ndarray, seed: int, keep: np.ndarray):
    """The prediction function of a per-pixel network fitted to the pixels (``STEPS`` Adam
    steps); it reads a view's features times ``keep`` as the fit did."""
    import torch

    torch.manual_seed(seed)
    mu, sd = x.mean(0), x.std(0) + 1e-3
    net = torch.nn.Sequential(torch.nn.Linear(x.shape[1], 32), torch.nn.ReLU(),
                              torch.nn.Linear(32, 32), torch.nn.ReLU(), torch.nn.Linear(32, 1))
    opt = torch.optim.Adam(net.parameters(), 3e-3)
    xt = torch.from_numpy((x - mu) / sd)
    yt, wt = torch.from_numpy(y), torch.from_numpy(w / w.mean())
    g = torch.Generator().manual_seed(seed)
    for _ in range(STEPS):
        b = torch.randint(0, len(xt), (8192,), generator=g)
        loss = torch.nn.functional.binary_cross_entropy_with_logits(net(xt[b])[:, 0], yt[b],
                                                                    weight=wt[b])
        opt.zero_grad()
        loss.backward()
        opt.step()

    def predict(v: dict) -> np.ndarray:
        x = v["x"].reshape(len(FEATURES), -1).T * keep
        with torch.no_grad():
            z = net(torch.from_numpy((x - mu) / sd))[:, 0]
        return torch.sigmoid(z).numpy().reshape(v["truth"].shape)

    return predict


def pooled_iou(pairs) -> float | None:
    """Flare IoU of (mask, truth) pairs pooled over views (None where both are empty)."""
    inter = sum(int((m & t).sum()) for m, t in pairs)
    union = sum(int((m | t).sum()) for m, t in pairs)
    return inter / union if union else None


def kind_means(rows: dict[str, float | None]) -> dict[str, float]:
    """{kind: mean IoU over its scenes} of {<build>_<scene>_<kind>: IoU}, None left out (the
    kind read as ``mask_faint.py`` reads it)."""
    from mask_faint import kind_of

    out: dict[str, list[float]] = {}
    for name, v in rows.items():
        if v is not None:
            out.setdefault(kind_of(name), []).append(v)
    return {k: float(np.mean(v)) for k, v in sorted(out.items())}


def scene_of(name: str) -> str:
    """The development workspace of a feature folder ``<build>_<scene>_<kind>``."""
    return name.rsplit("_", 2)[1]


def one_fold(data: dict[str, list[dict]], held: str, drop: tuple[str, ...], seed: int,
             clean: list[dict] | None) -> dict:
    """Fit on the scenes of ``data`` ({folder name: views}) of the other workspaces without
    the features of ``drop``, score the ``held`` workspace's, and the share marked of its
    ``clean`` views."""
    keep = kept(drop)
    train = [views for name, views in data.items() if scene_of(name) != held]
    test = {name: views for name, views in data.items() if scene_of(name) == held}
    predict = fit(*training_pixels(train, np.random.default_rng(seed), keep), seed, keep)
    preds = [[predict(v) for v in views] for views in train]

    def train_mean(cut: float) -> float:
        v = [pooled_iou([(p > cut, x["truth"]) for p, x in zip(ps, views, strict=True)])
             for ps, views in zip(preds, train, strict=True)]
        return float(np.mean([i for i in v if i is not None]))

    cut = max(CUTS, key=train_mean)
    stage, fused = {}, {}
    for name, views in test.items():
        if not any(v["truth"].any() for v in views):
            continue
        stage[name] = pooled_iou([(v["base"], v["truth"]) for v in views])
        fused[name] = pooled_iou([(predict(v) > cut, v["truth"]) for v in views])
    row = {"held_out": held, "without": list(drop), "fit_seed": seed, "cut": cut,
           "stage": kind_means(stage), "fusion": kind_means(fused)}
    row["stage_mean"] = float(np.mean(list(row["stage"].values())))
    row["fusion_mean"] = float(np.mean(list(row["fusion"].values())))
    if clean is not None:
        row["clean_stage"] = float(np.mean([v["base"].mean() for v in clean]))
        row["clean_fusion"] = float(np.mean([(predict(v) > cut).mean() for v in clean]))
    return row


def scene_folders(work: Path) -> list[Path]:
    """The feature folders of synth scenes under WORK/feats (the clean ones left out)."""
    feats = work / "feats"
    if not feats.is_dir():
        return []
    return sorted(f for f in feats.iterdir() if f.is_dir() and not f.name.endswith("_posed"))


def folds(work: Path, seeds: list[int]) -> list[dict]:
    """``folds``: every held-out workspace, with and without ``CROSS_VIEW``, every seed; each
    folder read once."""
    folders = scene_folders(work)
    data = {f.name: load_views(f) for f in folders}
    rows = []
    for held in sorted({scene_of(f.name) for f in folders}):
        clean = work / "feats" / f"{held}_ws_posed"
        clean_views = load_views(clean) if clean.is_dir() else None
        for drop in ((), CROSS_VIEW):
            for seed in seeds:
                r = one_fold(data, held, drop, seed, clean_views)
                print(f"{held} without {drop or '-'} seed {seed}: stage {r['stage_mean']:.3f} "
                      f"fusion {r['fusion_mean']:.3f}", flush=True)
                rows.append(r)
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    f = sub.add_parser("features")
    f.add_argument("synth", type=Path, nargs="*")
    f.add_argument("--posed", type=Path, action="append", default=[])
    f.add_argument("--work", type=Path, required=True)
    g = sub.add_parser("folds")
    g.add_argument("work", type=Path)
    g.add_argument("--fit-seeds", default="0,1")
    g.add_argument("--out", type=Path)
    a = ap.parse_args(argv)
    from workflows.threads import apply_thread_policy

    apply_thread_policy()
    if a.cmd == "features":
        bad = ([s for s in a.synth if not (s / "masks_gt").is_dir()],
               [w for w in a.posed if not (w / "cameras.json").is_file()])
        if bad[0]:
            print(f"error: {bad[0][0]}: not a synth scene (no masks_gt/): pass a folder made "
                  "by `deflare-scene synth`", file=sys.stderr)
            return 2
        if bad[1]:
            print(f"error: {bad[1][0]}: not a posed workspace (no cameras.json): run "
                  f"`deflare-scene pose {bad[1][0]}` first", file=sys.stderr)
            return 2
        features([s.resolve() for s in a.synth], [w.resolve() for w in a.posed], a.work)
        return 0
    if not scene_folders(a.work):
        print(f"error: {a.work}: no scene features under feats/: run `mask_fusion.py features "
              f"SYNTH ... --work {a.work}` first", file=sys.stderr)
        return 2
    from pipeline.provenance import write_result

    rows = folds(a.work, [int(s) for s in a.fit_seeds.split(",")])
    write_result(a.out, {"features": list(FEATURES), "cross_view": list(CROSS_VIEW),
                         "steps": STEPS, "negatives": NEGATIVES, "rows": rows})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
