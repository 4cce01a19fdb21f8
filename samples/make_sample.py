"""Build the shipped sample scene from ../shared/data/scenes/cyprus (BSD-3-Clause).

    python samples/make_sample.py [--shared ../shared/data] [--size 504] [--seed 3]

decode (long side --size) -> pose (pycolmap) -> synth (one lens, one 3D light, 2 held-out
views) -> samples/cyprus/ (the flared photos a user would have, JPEG q=92) and
samples/cyprus_truth/ (clean ground truth, true flare masks, ground-truth cameras, split;
with ``photos`` linking to ../cyprus so that ``deflare-scene eval samples/cyprus_truth``
reads it as a synth folder).
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
from pathlib import Path

import cv2

from pipeline import decode, pose, synth
from pipeline.flare import FlareConfig

HERE = Path(__file__).resolve().parent

# a bright daylight scene hides weak flare: the sample uses the strong end of the ranges
SAMPLE_FLARE = FlareConfig(scatter_flux=(1.5e4, 5e4), intensity=(0.8, 2.0),
                           ghost_amplitude=(0.1, 0.3), glare_amplitude=(0.06, 0.15))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shared", type=Path, default=HERE.parents[1] / "shared" / "data")
    ap.add_argument("--size", type=int, default=504)
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--heldout", type=int, default=2)
    args = ap.parse_args()
    photos, truth = HERE / "cyprus", HERE / "cyprus_truth"
    with tempfile.TemporaryDirectory() as tmp:
        ws = decode.run(decode.DecodeConfig(max_size=args.size),
                        args.shared / "scenes" / "cyprus", Path(tmp) / "cyprus.deflare")
        pose.run(pose.PoseConfig(), ws)
        out = Path(tmp) / "synth"
        synth.run(synth.SynthConfig(out=out, seed=args.seed, heldout=args.heldout,
                                    intensity_jitter=0.5, flare=SAMPLE_FLARE), ws)
        for d in (photos, truth):
            shutil.rmtree(d, ignore_errors=True)
        (truth / "clean").mkdir(parents=True)
        photos.mkdir()
        jpeg = [cv2.IMWRITE_JPEG_QUALITY, 92]
        for p in sorted((out / "photos").glob("*.png")):
            cv2.imwrite(str(photos / f"{p.stem}.jpg"), cv2.imread(str(p)), jpeg)
        for p in sorted((out / "clean").glob("*.png")):
            cv2.imwrite(str(truth / "clean" / f"{p.stem}.png"), cv2.imread(str(p)))
        shutil.copytree(out / "masks_gt", truth / "masks_gt")
        for name in ("cameras_gt.json", "split.json", "README.md"):
            shutil.copy2(out / name, truth / name)
        (truth / "photos").symlink_to("../cyprus")
    print(f"wrote {photos} and {truth}")


if __name__ == "__main__":
    main()
