"""Overview image of the layered scenes `pretrain --layered` adds (docs/layered_scenes.jpg).

    python benchmarks/layered_overview.py [--scenes ../shared/data/scenes]
        [--out docs/layered_scenes.jpg] [--seed 0]

Three layered scenes (``workflows.research.layered_scenes.layered_scene``, the pretraining's
4:3 load size) with textures cut from the photos of the shippable training scenes (lund,
BSD-2-Clause, and maryrose and buddha, CC BY 4.0: ../shared/data/README.md), four of each
scene's twelve views per row: what the prior sees of such a world. Deterministic for a seed.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np

SHIPPABLE = ("lund", "maryrose", "buddha")
"""Training scenes whose photos may appear in what the project ships."""


def photos_of(root: Path, per_scene: int = 8) -> list[np.ndarray]:
    """The first ``per_scene`` photos of each shippable scene, RGB uint8, long side 504."""
    from pipeline.images import list_photos, read_image

    out = []
    for name in SHIPPABLE:
        for p in list_photos(root / name / "images")[:per_scene] if (root / name / "images"
                                                                     ).is_dir() else []:
            img = read_image(p)
            s = 504 / max(img.shape[:2])
            out.append(cv2.resize(img, None, fx=s, fy=s, interpolation=cv2.INTER_AREA))
    if not out:
        raise SystemExit(f"{root} holds none of {', '.join(SHIPPABLE)}: pass --scenes "
                         "../shared/data/scenes")
    return out


def main() -> None:
    from workflows.research.layered_scenes import layered_scene

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=Path,
                    default=Path(__file__).resolve().parents[2] / "shared" / "data" / "scenes")
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1] / "docs" /
                    "layered_scenes.jpg")
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args()
    photos = photos_of(a.scenes)
    rng = np.random.default_rng(a.seed)
    rows = []
    for i in range(3):
        scene = layered_scene(photos, rng, f"layered{i}")
        views = scene.images[[0, 4, 8, 11]].permute(0, 2, 3, 1).numpy()
        rows.append(np.concatenate([cv2.resize(v, (252, 189), interpolation=cv2.INTER_AREA)
                                    for v in views], 1))
    grid = np.concatenate(rows, 0)
    a.out.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(a.out), grid[..., ::-1], [cv2.IMWRITE_JPEG_QUALITY, 85])
    print(f"wrote {a.out} ({a.out.stat().st_size // 1000} KB)")


if __name__ == "__main__":
    main()
