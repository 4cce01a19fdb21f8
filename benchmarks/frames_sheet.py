"""A contact sheet of rendered paths: one row per folder of frames, every N-th frame.

    python benchmarks/frames_sheet.py DIR[=LABEL] [DIR[=LABEL] ...] [--every 4]
        [--height 160] --out SHEET.jpg

Each DIR holds a path's frames (``WS/renders/<path>/00000.png`` ...); the row shows frames
0, N, 2N, ... of it, each labelled with its number (and the row's first with LABEL), so two
renders of one path (two settings) can be compared frame by frame.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def labelled_row(cells: list[tuple[np.ndarray, str]], height: int) -> np.ndarray:
    """One BGR row of (image, label) cells, each scaled to ``height`` and labelled."""
    import cv2

    from pipeline.images import put_label

    out = []
    for img, label in cells:
        w = max(1, round(img.shape[1] * height / img.shape[0]))
        cell = np.ascontiguousarray(cv2.resize(img, (w, height), interpolation=cv2.INTER_AREA))
        put_label(cell, label)
        out.append(cell)
    return np.concatenate(out, axis=1)


def padded(rows: list[np.ndarray]) -> list[np.ndarray]:
    """``rows`` each padded on the right with black to the widest."""
    width = max(r.shape[1] for r in rows)
    return [np.pad(r, ((0, 0), (0, width - r.shape[1]), (0, 0))) for r in rows]


def stacked(rows: list[np.ndarray]) -> np.ndarray:
    """``rows`` one above the other, padded to the widest."""
    return np.concatenate(padded(rows), axis=0)


def sheet_rows(folders: list[tuple[Path, str]], every: int, height: int) -> list[np.ndarray]:
    """One BGR row per (folder, label): every ``every``-th frame scaled to ``height``."""
    from pipeline.images import read_image

    rows = []
    for folder, label in folders:
        frames = sorted(folder.glob("[0-9]*.png"))
        if not frames:
            raise SystemExit(f"error: {folder}: no frames (00000.png ...); give a render's "
                             "folder, e.g. WS/renders/interpolate")
        rows.append(labelled_row([(read_image(f, bgr=True),
                                   f"{label} {f.stem}" if k == 0 and label else f.stem)
                                  for k, f in enumerate(frames[::every])], height))
    return padded(rows)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folders", nargs="+", help="DIR or DIR=LABEL")
    ap.add_argument("--every", type=int, default=4)
    ap.add_argument("--height", type=int, default=160)
    ap.add_argument("--out", type=Path, required=True)
    a = ap.parse_args(argv)
    if a.every < 1 or a.height < 8:
        raise SystemExit("error: --every must be at least 1 and --height at least 8")
    import cv2

    folders = [(Path(d.split("=", 1)[0]), d.split("=", 1)[1] if "=" in d else "")
               for d in a.folders]
    rows = sheet_rows(folders, a.every, a.height)
    a.out.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(a.out), stacked(rows), [cv2.IMWRITE_JPEG_QUALITY, 80])
    print(f"wrote {a.out} ({len(rows)} rows)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
