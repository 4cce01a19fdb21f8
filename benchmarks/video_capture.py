"""A photo sequence filmed as a video, and what the one-shot made of it.

    python benchmarks/video_capture.py make ../shared/data/scenes/fox/images /tmp/foxvid --fps 10
    deflare-scene /tmp/foxvid                     # decode takes the video's frames
    python benchmarks/video_capture.py summary /tmp/foxvid.deflare --out RESULT.json

``make`` writes ``OUT/<name>.mp4`` (H.264, the frames in name order at full size), the kind
of file a phone gives. ``summary`` records the frames decode took (index, time), how many
registered in the pose, the mask stage's flare fractions and every stage's seconds.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))


def make(frames: Path, out: Path, fps: float, crf: int) -> Path:
    from pipeline.images import list_photos, read_image
    from pipeline.video import write_video

    files = list_photos(frames)
    out.mkdir(parents=True, exist_ok=True)
    name = frames.parent.name if frames.name == "images" else frames.name
    return write_video(out / f"{name}.mp4", (read_image(p) for p in files), fps=fps, crf=crf)


def summary(ws_path: Path) -> dict:
    from pipeline.workspace import Workspace
    from pipeline.ws_files import read_cameras

    ws = Workspace.open(ws_path)
    decode = ws.stage_record("decode")
    report = json.loads((ws.root / "colmap" / "report.json").read_text())
    flare = json.loads(ws.flare_json.read_text()) if ws.flare_json.exists() else {}
    return {
        "workspace": str(ws.root),
        "frames_taken": decode.get("video_frames", {}),
        "registered": report["registered"], "images": report["images"],
        "views_posed": len(read_cameras(ws).frames),
        "flare_fraction": {s: v.get("flare_fraction") for s, v in
                           flare.get("views", {}).items()},
        "stages": ws.stage_summary(),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    m = sub.add_parser("make", help="an image sequence -> OUT/<name>.mp4")
    m.add_argument("frames", type=Path)
    m.add_argument("out", type=Path)
    m.add_argument("--fps", type=float, default=10.0)
    m.add_argument("--crf", type=int, default=20)
    s = sub.add_parser("summary", help="what the one-shot made of a video's workspace")
    s.add_argument("workspace", type=Path)
    s.add_argument("--out", type=Path)
    a = ap.parse_args()
    if a.cmd == "make":
        print(make(a.frames, a.out, a.fps, a.crf))
        return
    from pipeline.provenance import write_result

    print(json.dumps(write_result(a.out, summary(a.workspace)), indent=1, default=str))


if __name__ == "__main__":
    main()
