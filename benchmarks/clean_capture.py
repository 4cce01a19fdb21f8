"""What the main job changes in the photos of a capture that has no flare.

    python benchmarks/clean_capture.py WS [--out JSON]

WS is a workspace the one-shot command (or the stages up to `render --path inputs`) finished
on photos with no lens flare, e.g. `deflare-scene ../shared/data/scenes/lund/images --out
WS`. Nothing in them should change; whatever the masks mark is filled from the other photos
and GN-FR. For every view this compares the de-flared photo (WS/deflared) with the decoded
photo it was made from (WS/decoded, the same framing and size): the share of the pixels the
masks marked (WS/masks, in the undistorted geometry), the share that changed by more than 2
of 255 in any channel, and the PSNR of the whole photo and of the changed pixels against the
photo; where the stage kept the network's own masks (WS/masks_fmg: the other photos'
check ran) also the share those mark, the share the check added (and how many of its pixels
lie in regions touching the network's marks), and the share of the ghost-line candidates it
judged (WS/masks_ghosts); with the mean over the views. It also
reports the stage
times of the workspace's manifest, so a run doubles as a timing of a capture that size.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def view_row(photo: np.ndarray, deflared: np.ndarray, mask: np.ndarray) -> dict:
    """The comparison of one view: ``photo`` and ``deflared`` uint8 [H, W, 3] of the same
    framing, ``mask`` [h, w] bool (its own geometry: only its share is used)."""
    from pipeline.metrics import psnr

    a, b = photo.astype(np.float32) / 255, deflared.astype(np.float32) / 255
    changed = (np.abs(photo.astype(np.int16) - deflared.astype(np.int16)) > 2).any(-1)
    return {"marked": round(float(mask.mean()), 5), "changed": round(float(changed.mean()), 5),
            "psnr": round(float(psnr(b, a)), 2) if changed.any() else None,
            "psnr_changed": round(float(psnr(b[changed], a[changed])), 2)
            if changed.any() else None}


def touching_regions(added: np.ndarray, own: np.ndarray) -> np.ndarray:
    """[H, W] bool: the 8-connected regions of ``added`` that touch ``own`` (both [H, W]
    bool; a region next to the network's marks may be their halo):
    ``pipeline.mask.confirmed_regions`` against ``own`` grown by a pixel."""
    import cv2

    from pipeline.mask import confirmed_regions

    near = cv2.dilate(own.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
    return confirmed_regions(added, near, "first")


def touching(added: np.ndarray, own: np.ndarray) -> int:
    """Pixels of ``touching_regions``."""
    return int(touching_regions(added, own).sum())


def read_mask(folder: Path, stem: str) -> np.ndarray:
    """[H, W] bool of the WS mask ``folder/<stem>.png``."""
    from pipeline.ws_files import read_mask_file

    return read_mask_file(folder / f"{stem}.png")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("ws", type=Path)
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    from pipeline.errors import UserError
    from pipeline.images import read_image
    from pipeline.provenance import write_result
    from pipeline.workspace import Workspace

    try:
        ws = Workspace.open(a.ws)
        stems = sorted(p.stem for p in (a.ws / "deflared").glob("*.png"))
        if not stems:
            raise UserError(f"{a.ws}/deflared holds no photos: run `deflare-scene render "
                            f"{a.ws} --path inputs` (or the one-shot command) first")
        views = {}
        for s in stems:
            photo = read_image(ws.decoded_path(s), bgr=True)
            mask = read_mask(a.ws / "masks", s)
            views[s] = view_row(photo, read_image(a.ws / "deflared" / f"{s}.png", bgr=True),
                                mask)
            if (a.ws / "masks_fmg" / f"{s}.png").is_file():
                own = read_mask(a.ws / "masks_fmg", s)
                views[s]["marked_network"] = round(float(own.mean()), 5)
                views[s]["added_by_views"] = round(float((mask & ~own).mean()), 5)
                views[s]["added_pixels"] = int((mask & ~own).sum())
                views[s]["added_pixels_touching_network"] = touching(mask & ~own, own)
            if (a.ws / "masks_ghosts" / f"{s}.png").is_file():
                views[s]["ghost_candidates"] = round(float(
                    read_mask(a.ws / "masks_ghosts", s).mean()), 5)
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    mean = {k: round(float(np.mean([v[k] for v in views.values()])), 5)
            for k in ("marked", "changed", "marked_network", "added_by_views",
                      "ghost_candidates") if all(k in v for v in views.values())}
    scored = [v["psnr"] for v in views.values() if v["psnr"] is not None]
    mean["psnr_changed_views"] = round(float(np.mean(scored)), 2) if scored else None
    stages = ws.stage_summary()
    print(f"{a.ws.name}: {len(views)} views, marked {100 * mean['marked']:.2f} %, changed "
          f"{100 * mean['changed']:.2f} % of the pixels")
    if a.out:
        write_result(a.out, {"workspace": str(a.ws), "views": views, "mean": mean,
                             "stages": stages})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
