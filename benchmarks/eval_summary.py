"""Combine several `deflare-scene eval` results (scenes, seeds, settings) into one table.

    python benchmarks/eval_summary.py EVAL_WS/eval/results.json [...] [--md out.md]

One row per (results file, method): the scene it came from, seed, init, mask source,
colour match, held-out PSNR / SSIM, inputs PSNR / SSIM, flare-region PSNR. Seed, init (the
start weights and the first 8 hex of their sha256), steps and colour match are read from
each method's provenance (its checkpoint and render records) when the file has it; a file
written before eval recorded provenance shows the options it was asked for, marked
"(asked)", and its commit as "—". Then, for every
file that scored both GN-FR and vanilla GNT, the GN-FR minus GNT difference inside the
flare region and on held-out views, and their mean over files (the issue's goal: +2 dB
inside the flare region at the quick preset).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path


def _f(x, nd: int = 2) -> str:
    return "—" if x is None else f"{x:.{nd}f}"


def rows_of(path: Path) -> tuple[dict, list[dict]]:
    r = json.loads(path.read_text())
    b = r.get("budget", {})
    commit = ((r.get("provenance") or {}).get("code") or {}).get("commit")
    setting = {"file": str(path), "scene": r.get("origin", "?"), "seed": b.get("seed"),
               "init": b.get("init"), "masks": r.get("masks"),
               "color_match": b.get("color_match", False), "iters": b.get("iters"),
               "miou": (r.get("mask_scores") or {}).get("miou"),
               "commit": commit[:8] if commit else "—"}
    rows = []
    for name, m in r["methods"].items():
        h, i = m.get("heldout", {}), m.get("inputs", {})
        rows.append({"method": name, "heldout_psnr": h.get("psnr"),
                     "heldout_ssim": h.get("ssim"), "inputs_psnr": i.get("psnr"),
                     "inputs_ssim": i.get("ssim"), "flare_psnr": i.get("psnr_flare"),
                     **trained(m, setting)})
    return setting, rows


def trained(m: dict, setting: dict) -> dict:
    """seed / init / steps / colour match of one method: from its provenance (checkpoint)
    when recorded, else the options the file was asked for, marked "(asked)"."""
    sm = (m.get("provenance") or {}).get("summary")
    kind = (m.get("provenance") or {}).get("kind")
    if kind == "baseline" or (kind is None and "train" not in m):  # no model trained
        return {"seed": "—", "init": "—", "steps": "—", "color_match": "—"}
    if sm and sm.get("from_checkpoint"):
        init = "scratch" if not sm["init_sha256"] else \
            f"{sm['trained_from']}@{sm['init_sha256'][:8]}"
        cm = sm.get("color_match")
        return {"seed": sm["seed"], "init": init, "steps": sm["steps_done"],
                "color_match": "—" if cm is None else ("on" if cm else "off")}
    steps = (m.get("train") or {}).get("steps", setting["iters"])
    return {"seed": f"{setting['seed']} (asked)", "init": f"{setting['init']} (asked)",
            "steps": steps, "color_match": f"{'on' if setting['color_match'] else 'off'} "
                                           "(asked)"}


def summarise(paths: list[Path]) -> str:
    out = ["| scene | commit | seed | init | masks (mIoU) | colour match | steps | method | "
           "held-out PSNR / SSIM | inputs PSNR / SSIM | flare-region PSNR |",
           "|---|---|---|---|---|---|---|---|---|---|---|"]
    gaps = []
    for p in paths:
        s, rows = rows_of(p)
        masks = s["masks"] + (f" ({s['miou']:.3f})" if s["miou"] is not None else "")
        for r in rows:
            out.append(f"| {s['scene']} | {s['commit']} | {r['seed']} | {r['init']} | {masks} | "
                       f"{r['color_match']} | {r['steps']} | {r['method']} | "
                       f"{_f(r['heldout_psnr'])} / {_f(r['heldout_ssim'], 3)} | "
                       f"{_f(r['inputs_psnr'])} / {_f(r['inputs_ssim'], 3)} | "
                       f"{_f(r['flare_psnr'])} |")
        by = {r["method"]: r for r in rows}
        if "gnfr" in by and "gnt" in by:
            g, t = by["gnfr"], by["gnt"]
            held = (None if g["heldout_psnr"] is None or t["heldout_psnr"] is None
                    else g["heldout_psnr"] - t["heldout_psnr"])
            gaps.append((s, g["flare_psnr"] - t["flare_psnr"], held))
    if gaps:
        out += ["", "| scene | seed | colour match | GN-FR - GNT, flare region | GN-FR - GNT, "
                "held-out |", "|---|---|---|---|---|"]
        for s, fl, held in gaps:
            out.append(f"| {s['scene']} | {s['seed']} | {'on' if s['color_match'] else 'off'}"
                       f" | {fl:+.2f} dB | {'—' if held is None else f'{held:+.2f} dB'} |")
        mean_fl = sum(g[1] for g in gaps) / len(gaps)
        helds = [g[2] for g in gaps if g[2] is not None]
        mean_h = f"{sum(helds) / len(helds):+.2f} dB" if helds else "—"
        out.append(f"| **mean of {len(gaps)}** | | | **{mean_fl:+.2f} dB** | {mean_h} |")
    return "\n".join(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("results", type=Path, nargs="+")
    ap.add_argument("--md", type=Path, default=None, help="Also write the tables here.")
    a = ap.parse_args()
    text = summarise(a.results)
    print(text)
    if a.md:
        a.md.write_text(text + "\n")


if __name__ == "__main__":
    main()
