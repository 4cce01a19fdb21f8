"""Pack training scenes into small files to move them to another machine (a lent GPU's).

``python -m workflows.research.scene_pack SCENE... --out DIR [--max-size 504]`` loads each
scene the way ``deflare-scene pretrain`` finds and loads it (workspaces, LLFF and COLMAP
folders, or folders of them; the held-out evaluation scenes are left out) and writes
``DIR/<scene>/scene_pack.npz`` (``pipeline.training_scenes.save_pack``: JPEG views and
cameras, a few MB per scene). ``pretrain DIR`` then reads the packs like any scene.

``python -m workflows.research.scene_pack --fmg-photos DATA --out DIR`` instead copies the
photos the FMG trains and scores on (every image under ``DATA/backgrounds`` and
``DATA/scenes``, ``pipeline.fmg_data.split_backgrounds``) to the same relative paths under
DIR, shrunk to the long side FMG training loads them at (512) and saved as JPEG:
``fmg train --data DIR`` then splits and loads them as it would the originals.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from pipeline.errors import UserError
from pipeline.progress import info


def pack_fmg_photos(data: Path, out: Path, long_side: int = 512, quality: int = 92) -> int:
    """Copy the FMG's photos of ``data`` under ``out`` (same relative paths, ``.jpg``),
    shrunk like ``load_backgrounds`` does; returns how many were written."""
    import cv2

    from pipeline.fmg_data import find_images, load_backgrounds

    written: set[Path] = set()
    for sub in ("backgrounds", "scenes"):
        if not (data / sub).is_dir():
            continue
        for p in find_images(data / sub):
            imgs = load_backgrounds([p], long_side)  # RGB, shrunk as training does
            if not imgs:
                continue
            dest = out / p.relative_to(data).with_suffix(".jpg")
            if dest in written:  # x.png beside x.jpg: one would overwrite the other
                raise UserError(f"{p}: another photo of that folder has the same name; "
                                "rename one of them")
            written.add(dest)
            dest.parent.mkdir(parents=True, exist_ok=True)
            cv2.imwrite(str(dest), imgs[0][..., ::-1], [cv2.IMWRITE_JPEG_QUALITY, quality])
    return len(written)


def main(argv: list[str] | None = None) -> int:
    from pipeline.training_scenes import detect_and_load, save_pack, shrink_scene
    from workflows.research.pretrain import find_scenes

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", type=Path, nargs="*")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--max-size", type=int, default=504)
    ap.add_argument("--quality", type=int, default=None,
                    help="JPEG quality, 1-100 (default 95 for scenes, 92 for --fmg-photos)")
    ap.add_argument("--fmg-photos", type=Path, default=None,
                    help="DATA folder (backgrounds/, scenes/) whose FMG photos to copy")
    args = ap.parse_args(argv)
    if args.quality is not None and not 1 <= args.quality <= 100:
        raise SystemExit(f"error: --quality {args.quality}: give 1-100")
    try:
        if args.fmg_photos is not None:
            n = pack_fmg_photos(args.fmg_photos, args.out, quality=args.quality or 92)
            info(f"{n} photos of {args.fmg_photos} -> {args.out}")
            return 0
        if not args.scenes:
            raise SystemExit("error: give scene folders to pack, or --fmg-photos DATA")
        for folder in find_scenes(args.scenes):
            # workspaces load at their own size: packs are all at most --max-size
            scene = shrink_scene(detect_and_load(folder, args.max_size), args.max_size)
            path = save_pack(scene, args.out / folder.name, args.quality or 95)
            info(f"{folder} -> {path} ({len(scene.stems)} views, "
                 f"{path.stat().st_size / 2**20:.1f} MiB)")
    except UserError as e:
        raise SystemExit(f"error: {e}") from None
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
