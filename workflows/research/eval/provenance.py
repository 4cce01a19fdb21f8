"""What scored a results file and what trained and rendered each method (read from WS)."""

from __future__ import annotations

import time
from pathlib import Path

from pipeline.workspace import Workspace
from pipeline.ws_files import read_flare
from workflows.research.eval.config import NEURAL, EvalConfig


def run_provenance(ws: Workspace) -> dict:
    """What scored this results file: code version, machine, the command, and the
    workspace's shared stage records (cameras, masks with their source and cut, depth,
    View Sampler), read from WS, not from the code's defaults."""
    from pipeline.provenance import code_version, command_line, machine

    def params(stage: str) -> dict | None:
        rec = ws.stage_record(stage)
        return None if not rec else {"params": rec.get("params"), "status": rec.get("status"),
                                     "started": rec.get("started"),
                                     "seconds": rec.get("seconds")}

    masks = {"source": None, "threshold": None, "weights": None}
    if ws.flare_json.exists():
        flare = read_flare(ws)
        masks = {"source": flare.source, "threshold": flare.threshold,
                 "weights": flare.weights}
    return {"code": code_version(), "machine": machine(), "command": command_line(),
            "scored": time.strftime("%Y-%m-%dT%H:%M:%S"), "workspace": str(ws.root),
            "cameras": params("pose"), "masks": {**masks, "stage": params("mask")},
            "depth": params("depth"), "select": params("select")}


def method_provenance(name: str, method: dict, base: Workspace) -> dict:
    """What trained and rendered one method, read from its workspace: for a neural variant
    the checkpoint's metadata (``provenance`` written by finetune: start weights and their
    sha256, preset numbers, seed, steps done, device, training seconds, code), the
    checkpoint's own sha256 and the finetune / render stage records (colour match, fill,
    render size, sources)."""
    if name not in NEURAL:
        used = {"input": [], "inpaint": ["masks"], "photos": ["masks", "depth"]}[name]
        return {"kind": "baseline", "uses": used}
    from gnfr.checkpoint import read_metadata
    from pipeline.provenance import sha256

    variant_ws = Workspace(method["workspace"])
    ckpt = variant_ws.model_file
    _, meta = read_metadata(ckpt)
    prov = meta.pop("provenance", None)
    fin = variant_ws.stage_record("finetune")
    renders = {stage: {"params": rec.get("params"), "seconds": rec.get("seconds"),
                       "started": rec.get("started"), "frames": rec.get("frames")}
               for stage, rec in variant_ws.manifest()["stages"].items()
               if stage.startswith("render:")}
    out = {"kind": "neural", "parts": NEURAL[name], "checkpoint": str(ckpt),
           "checkpoint_sha256": sha256(ckpt), "checkpoint_meta": meta,
           "trained": prov, "finetune_stage": {k: fin.get(k) for k in (
               "params", "started", "seconds", "steps", "it_per_s", "train_seconds", "init",
               "versions")}, "renders": renders}
    out["summary"] = provenance_summary(prov, fin, renders)
    return out


def provenance_summary(prov: dict | None, fin: dict, renders: dict) -> dict:
    """The few facts a table prints, from the checkpoint (None where it does not say)."""
    inputs = (renders.get("render:inputs") or {}).get("params") or {}
    held = [r["params"] for k, r in renders.items() if k != "render:inputs" and r["params"]]
    if prov is None:  # a checkpoint written before finetune recorded its provenance
        return {"from_checkpoint": False, "trained_from": None, "init_sha256": None,
                "cached_features": None, "steps_done": fin.get("steps"), "seed": None,
                "preset": (fin.get("params") or {}).get("preset"), "device": None,
                "train_seconds": fin.get("seconds"), "color_match": inputs.get("color_match"),
                "fill": inputs.get("fill"), "heldout_fill": [h.get("fill") for h in held]}
    init = prov.get("init") or {}
    return {"from_checkpoint": True,
            "trained_from": Path(init["weights"]).name if init.get("sha256") else "scratch",
            "init_sha256": init.get("sha256"), "cached_features": prov.get("cached_features"),
            "steps_done": prov.get("steps_done"), "seed": prov.get("seed"),
            "preset": prov.get("preset"), "device": prov.get("device_name"),
            "train_seconds": prov.get("train_seconds"),
            "color_match": inputs.get("color_match"), "fill": inputs.get("fill"),
            "heldout_fill": [h.get("fill") for h in held]}


def budget(cfg: EvalConfig) -> dict:
    """What every neural variant was asked to run with (the options, resolved by the code
    that scores), beside the paper's setting. What actually trained each model is in its
    ``provenance`` (read from the checkpoint); the table reports that."""
    from pipeline.finetune import FinetuneConfig, pick_device, resolve, shipped_weights

    finetune_cfg = FinetuneConfig(preset=cfg.preset, iters=cfg.iters, rays=cfg.rays,
                                  samples=cfg.samples, views=cfg.views, device=cfg.device,
                                  init=cfg.init, **cfg.finetune_extra)
    device = pick_device(cfg.device)
    preset, train = resolve(finetune_cfg, device)
    return {"preset": preset, "device": device.type, "iters": train.iters, "rays": train.rays,
            "samples": train.samples, "depth": train.model.depth, "width": train.model.width,
            "source_scale": train.source_scale, "eval_views": train.eval_views,
            "cached_features": train.cached_features, "init": cfg.init,
            "init_weights": _init_weights(cfg.init, shipped_weights(train)),
            "render_scale": cfg.render_scale, "seed": cfg.seed,
            "color_match": cfg.color_match, "fill": cfg.fill}


def _init_weights(init: str, shipped: Path | None) -> str:
    """What ``init`` resolved to: 'scratch' or a weight file's name."""
    if init == "auto":
        return shipped.name if shipped is not None else "scratch"
    return init if init == "scratch" else Path(init).name

