"""Overview images of each kind of synthetic lens flare (docs/flare_kinds/<kind>.jpg).

    python benchmarks/flare_kinds_overview.py [--backgrounds ../shared/data/backgrounds]
        [--out docs/flare_kinds] [--seed 0] [--kinds starburst,ghosts,...]

For every kind of ``pipeline.flare.KINDS`` (and ``combined``, all kinds as drawn for
training data) it composites six examples with ``synthesize`` onto photos found under
``--backgrounds`` with the light somewhere in the frame, outlines each ground-truth mask in
translucent yellow and writes a 2 x 3 grid as a JPEG under 200 KB; each example is labelled
with the kinds it drew and its mask's share of the frame. Deterministic for a seed.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np

TILE = (320, 240)  # (width, height) of one example
MAX_BYTES = 200_000


def load_backgrounds(root: Path) -> list[np.ndarray]:
    """RGB uint8 photos under ``root`` (sorted), centre-cropped to 4:3 and resized to TILE."""
    from pipeline.errors import UserError
    from pipeline.images import list_photos, read_image

    out = []
    for p in list_photos(root, recursive=True):
        try:
            img = read_image(p, bgr=True)
        except UserError:
            continue
        h, w = img.shape[:2]
        ch, cw = (h, h * 4 // 3) if w * 3 >= h * 4 else (w * 3 // 4, w)
        y, x = (h - ch) // 2, (w - cw) // 2
        img = cv2.resize(img[y:y + ch, x:x + cw], TILE, interpolation=cv2.INTER_AREA)
        out.append(np.ascontiguousarray(img[..., ::-1]))
    return out


def example(img: np.ndarray, cfg, rng: np.random.Generator) -> np.ndarray:
    """[h, w, 3] uint8 BGR: ``img`` flared by ``synthesize``, its mask outlined."""
    from pipeline.flare import synthesize
    from pipeline.images import put_label

    h, w = img.shape[:2]
    light = (float(rng.uniform(0.15, 0.85) * w), float(rng.uniform(0.15, 0.85) * h))
    flared, layers = synthesize(img, cfg, rng, light)
    bgr = np.ascontiguousarray((np.clip(flared, 0, 1)[..., ::-1] * 255 + 0.5).astype(np.uint8))
    contours, _ = cv2.findContours(layers.mask.astype(np.uint8), cv2.RETR_LIST,
                                   cv2.CHAIN_APPROX_NONE)
    outlined = cv2.drawContours(bgr.copy(), contours, -1, (0, 255, 255), 1, cv2.LINE_8)
    bgr = cv2.addWeighted(bgr, 0.45, outlined, 0.55, 0.0)  # see the flare under the line
    label = "+".join(layers.kinds) + f"  mask {100 * layers.mask.mean():.1f}%"
    put_label(bgr, label, scale=0.38, bottom=True)
    return bgr


def write_jpeg(path: Path, bgr: np.ndarray) -> int:
    """Write ``bgr`` as the best-quality JPEG under MAX_BYTES; returns its size in bytes."""
    for quality in range(92, 40, -4):
        ok, buf = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, quality])
        if ok and len(buf) < MAX_BYTES:
            break
    path.write_bytes(buf.tobytes())
    return len(buf)


def overview(kind: str, backgrounds: list[np.ndarray], seed: int) -> np.ndarray:
    """[2 h, 3 w, 3] uint8 BGR grid of six examples of ``kind`` ('combined': all kinds)."""
    from pipeline.flare import KINDS, FlareConfig

    cfg = FlareConfig(kinds=KINDS if kind == "combined" else (kind,))
    rng = np.random.default_rng([seed, (("combined",) + KINDS).index(kind)])
    picks = rng.choice(len(backgrounds), 6, replace=len(backgrounds) < 6)
    tiles = [example(backgrounds[int(i)], cfg, rng) for i in picks]
    return np.vstack([np.hstack(tiles[:3]), np.hstack(tiles[3:])])


def main() -> None:
    from pipeline.flare import KINDS, check_kinds

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--backgrounds", type=Path,
                    default=Path(__file__).resolve().parents[2] / "shared/data/backgrounds")
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1] /
                    "docs/flare_kinds")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--kinds", default=",".join(KINDS) + ",combined")
    args = ap.parse_args()
    wanted = [k.strip() for k in args.kinds.split(",") if k.strip()]
    check_kinds([k for k in wanted if k != "combined"] or KINDS)
    backgrounds = load_backgrounds(args.backgrounds)
    if not backgrounds:
        raise SystemExit(f"no photos under {args.backgrounds}: pass --backgrounds")
    args.out.mkdir(parents=True, exist_ok=True)
    for kind in wanted:
        path = args.out / f"{kind}.jpg"
        size = write_jpeg(path, overview(kind, backgrounds, args.seed))
        print(f"{path}: {size / 1000:.0f} KB")


if __name__ == "__main__":
    main()
