"""Pack training scenes into small files to move them to another machine (a lent GPU's).

``python -m workflows.research.scene_pack SCENE... --out DIR [--max-size 504]`` loads each
scene the way ``deflare-scene pretrain`` finds and loads it (workspaces, LLFF and COLMAP
folders, or folders of them; the held-out evaluation scenes are left out) and writes
``DIR/<scene>/scene_pack.npz`` (``pipeline.training_scenes.save_pack``: JPEG views and
cameras, a few MB per scene). ``pretrain DIR`` then reads the packs like any scene.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from pipeline.errors import UserError
from pipeline.progress import info


def main(argv: list[str] | None = None) -> int:
    from pipeline.training_scenes import detect_and_load, save_pack
    from workflows.research.pretrain import find_scenes

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", type=Path, nargs="+")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--max-size", type=int, default=504)
    ap.add_argument("--quality", type=int, default=95, help="JPEG quality (1-100)")
    args = ap.parse_args(argv)
    try:
        for folder in find_scenes(args.scenes):
            scene = detect_and_load(folder, args.max_size)
            path = save_pack(scene, args.out / folder.name, args.quality)
            info(f"{folder} -> {path} ({len(scene.stems)} views, "
                 f"{path.stat().st_size / 2**20:.1f} MiB)")
    except UserError as e:
        raise SystemExit(f"error: {e}") from None
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
