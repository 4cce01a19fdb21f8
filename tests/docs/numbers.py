"""What the docs-number tests share: the repo's paths, reading a result file, how the
docs write numbers, and the result files several pages quote."""

from __future__ import annotations

import json
import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
RESULTS = REPO / "docs" / "results"

FERN = "fern_llff_quick_cpu.json"  # the 11 750-step weights (flare protocol, old rows)
FERN2 = "fern_llff_quick_cpu_w27250.json"  # the 27 250-step weights (clean)
FERN18 = "fern_llff_quick_cpu_w18500.json"  # the 18 500-step weights (clean)
FERN3 = "fern_llff_quick_cpu_w32500.json"  # the 32 500-step weights (clean)
FERN4 = "fern_llff_quick_cpu_w42250.json"  # the shipped 42 250-step weights (clean)
SAMPLE = "sample_oneshot_cpu.json"
PERF = "docs/performance.md"  # speed and memory (the README keeps a summary)


def result(name: str) -> dict:
    """A result file of docs/results/, parsed."""
    return json.loads((RESULTS / name).read_text())


def get(obj, path: str):
    """The value at a '/'-separated path of a result file (list items by index)."""
    for part in path.split("/"):
        obj = obj[int(part)] if isinstance(obj, list) else obj[part]
    return obj


def assert_quoted(page: str, file: str, path: str, fmt: str) -> None:
    """The page writes the value at ``path`` of ``file`` as ``fmt`` formats it."""
    value = get(result(file), path)
    text = (REPO / page).read_text()
    assert fmt.format(value) in text, f"{page} should quote {fmt.format(value)} ({file}: {path})"


def fill_row(name: str, fill: str) -> dict:
    """bench_cpu.json's render row of a fill ('network' or 'hybrid') at size x1 or x2."""
    bench = result("bench_cpu.json")
    rows = bench["results"]["cpu"]["render_workspace"]["rows"]
    return rows[[(r["fill"], r["size"][0] > 600) for r in rows].index((fill, name == "x2"))]


def spaced(n: int) -> str:
    """A count as the docs write it (thin groups of three: 13 597)."""
    return f"{n:,}".replace(",", " ")


def page_text(path: str) -> str:
    """A page's text with its line breaks and runs of spaces made single spaces."""
    return " ".join((REPO / path).read_text().split())


def _between(path: str, start: str, end: str) -> str:
    text = page_text(path)
    i = text.index(start)
    return text[i:text.index(end, i)]


def readme_notes() -> str:
    """The README's notes on its results rows as they read until the ninety-second session,
    kept in docs/eval.md ("The README's results, row by row") since the README became a
    summary."""
    return _between("docs/eval.md", "The README's notes on its rows, as they read until",
                    "Notes on the rows, as the README gave them until the fifty-first")


def readme_performance() -> str:
    """The README's "Performance" as it read until the ninety-second session, kept in
    docs/performance.md."""
    return _between(PERF, "## The README's summary, as it read until", "## The machine")


def recorded_walls(row_start: str) -> tuple[list[float], list[float]]:
    """The wall times (seconds) and peaks (GB) that docs/results/README.md's rows starting
    with the regex ``row_start`` record from `time -v` ("wall 8:13.5 and 7:47.6, peaks 1.04
    and 1.01 GB"), in row order."""
    walls, peaks = [], []
    for row in (RESULTS / "README.md").read_text().splitlines():
        if not re.match(row_start, row):
            continue
        m = re.search(r"wall ([\d:. and]+), peaks? ([\d. and]+) GB", row)
        assert m, row[:80]
        walls += [sum(float(x) * 60 ** i for i, x in enumerate(reversed(w.split(":"))))
                  for w in m.group(1).split(" and ")]
        peaks += [float(p) for p in m.group(2).split(" and ")]
    return walls, peaks


def clock(seconds: float) -> str:
    """A wall time as the pages write it to the second (16:05)."""
    return f"{int(seconds // 60)}:{round(seconds % 60):02d}"


def text_rows(name: str) -> list[list[str]]:
    """The words of each line of a text result file, its comments (#) and blank lines left."""
    return [ln.split() for ln in (RESULTS / name).read_text().splitlines()
            if ln and not ln.startswith("#")]


def time_seconds(*names: str) -> dict[str, float]:
    """``NAME SECONDS s`` lines of text result files (``/usr/bin/time``'s), by name."""
    return {row[0]: float(row[1]) for name in names for row in text_rows(name)}
