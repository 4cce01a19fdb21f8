"""What the FMG history's two test files share (tests/docs/test_history_masks.py, the
network's candidates; tests/docs/test_history_mask_rules.py, the mask stage's rules)."""

from __future__ import annotations

import pytest

from tests.conftest import load_benchmark
from tests.docs.numbers import RESULTS, result


def clean_triples(name: str, settings: tuple[str, ...]) -> list[str]:
    """Per setting of a `mask_views_scenes.py --posed` file, the share each clean
    development scene marks as the pages write it: "lund % / sceaux_castle % / et %"."""
    rows = result(name)["rows"]
    shares = {(r["scene"], r["setting"]): r["marked"] for r in rows}
    return [" / ".join(f"{100 * shares[(s, setting)]:.3f} %"
                       for s in ("lund.deflare", "sceaux_castle.deflare", "et.deflare"))
            for setting in settings]


def photo_verdict(candidate: str, baseline: str, seeds: list[int], saved: str,
                  decision: str) -> dict:
    """`fmg_photo_ab.py judge --rule speed` of two arms' committed files on the three
    development scenes, checked against its saved file (``decision`` and the means); the
    saved mean differences."""
    again = load_benchmark("fmg_photo_ab").judge(RESULTS, candidate, baseline,
                                                 ["sceaux", "et", "lund"], seeds, rule="speed")
    kept = result(saved)
    assert again["decision"] == kept["decision"] == decision
    assert again["mean"] == pytest.approx(kept["mean"])
    return kept["mean"]
