"""Flare a posed development workspace the way the shipped sample was flared.

    python benchmarks/synth_like_sample.py WS --out DIR [--seed S] [--heldout 2]

`deflare-scene synth` with the sample's settings (``samples/make_sample.py``: the strong end
of the flare ranges, ``SAMPLE_FLARE``, and an intensity jitter of 0.5 between views), which
the `synth` command's options do not reach: development scenes flared like the sample
(docs/history/fill.md, "The band where the ring check turns the photos down, on strong
flare").
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "samples"))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("ws", type=Path)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--heldout", type=int, default=2)
    a = ap.parse_args(argv)
    from make_sample import SAMPLE_FLARE

    from pipeline import synth
    from pipeline.errors import UserError
    from pipeline.workspace import Workspace

    try:
        synth.run(synth.SynthConfig(out=a.out, seed=a.seed, heldout=a.heldout,
                                    intensity_jitter=0.5, flare=SAMPLE_FLARE), Workspace(a.ws))
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
