"""What `mask --ghost-lines` adds to clean photos that show a light (synth scenes' clean views).

`deflare-scene synth` keeps, for every view, the clean photo with the light's own core drawn
in (`SYNTH/clean/`): a flare-free photo with a saturated light in it, which is where the
ghost-line rule (``pipeline.flare_ghosts``) could mark scene. For each synth folder this
scores the share of pixels the mask stage marks on those clean photos with the shipped FMG
(or ``--weights``) and the flare rays, without and with the ghost lines, and the share the
ghost lines add. Nothing on them is flare apart from the core, so every added mark is a false
one. Use development scenes to choose.

    python benchmarks/ghost_clean_views.py SYNTH [SYNTH ...] [--weights W] --out J
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def score_clean(model, cut: float, synth: Path, work_size: int = 512) -> dict:
    """Pooled share marked on ``synth``'s clean photos without / with the ghost lines."""
    from pipeline.errors import UserError
    from pipeline.flare_ghosts import GhostConfig
    from pipeline.images import list_photos, read_image
    from pipeline.mask import flare_marks, fmg_probs, ghost_marks, lights_at_work_size

    if not (synth / "clean").is_dir():
        raise UserError(f"{synth}: no clean/ folder; pass folders written by `deflare-scene "
                        "synth`")
    base = added = pixels = views = 0
    for photo in list_photos(synth / "clean"):
        img = read_image(photo, bgr=True)
        p = fmg_probs(model, [img], work_size)[0]
        found = lights_at_work_size(img, work_size)  # one light search for both
        without = flare_marks(model, img, cut, work_size, rays=True, probs=p, found=found)
        # what `flare_marks(..., ghosts=...)` adds: the ghost-line regions (the rays once)
        base += int(without.sum())
        added += int((ghost_marks(img, p, work_size, GhostConfig(), found) & ~without).sum())
        pixels += without.size
        views += 1
    return {"scene": synth.name, "views": views, "marked": base / max(pixels, 1),
            "added_by_ghost_lines": added / max(pixels, 1)}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", type=Path, nargs="+")
    ap.add_argument("--weights", type=Path, default=None)
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    from pipeline.errors import UserError
    from pipeline.mask import DEFAULT_WEIGHTS, MaskConfig, load_fmg_weights, resolve_threshold
    from pipeline.provenance import sha256, write_result

    weights = a.weights or DEFAULT_WEIGHTS
    try:
        model = load_fmg_weights(weights)
        cut = resolve_threshold(MaskConfig(), weights)
        rows = []
        for scene in a.scenes:
            rows.append(score_clean(model, cut, scene))
            r = rows[-1]
            print(f"{scene.name}: {r['views']} clean views, marked "
                  f"{100 * r['marked']:.3f} %, ghost lines add "
                  f"{100 * r['added_by_ghost_lines']:.3f} %", flush=True)
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    mean_added = float(np.mean([r["added_by_ghost_lines"] for r in rows]))
    print(f"mean over {len(rows)} scenes: ghost lines add {100 * mean_added:.3f} %")
    write_result(a.out, {"weights": str(weights), "sha256": sha256(weights), "cut": cut,
                         "rows": rows, "mean_added": mean_added})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
