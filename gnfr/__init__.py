"""GN-FR neural library (no workspace, CLI or file-layout knowledge).

Importing it before torch makes OpenMP threads sleep instead of spin while they wait
(``OMP_WAIT_POLICY=PASSIVE``, unless already set): on a shared 2-core machine spinning
threads made a training step 20-30x slower (see docs/presets.md). The variable is read once,
when torch's OpenMP runtime loads, so entry points set it too.
"""

import os
from pathlib import Path

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

WEIGHTS_DIR = Path(__file__).resolve().parent / "weights"
"""The shipped weight files (gnfr.safetensors, fmg.safetensors) and their model cards."""
