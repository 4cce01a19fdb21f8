"""The evaluation's outputs: results.json, table.md (with provenance) and grid.jpg."""

from __future__ import annotations

import json

import cv2
import numpy as np

from pipeline.progress import info
from pipeline.workspace import Workspace, atomic_imwrite, atomic_write_json, atomic_write_text
from workflows.research.eval.config import EvalConfig
from workflows.research.eval.scene import SynthScene, flared_views, truth_mask
from workflows.research.eval.scoring import read_bgr


def write_outputs(cfg: EvalConfig, scene: SynthScene, base: Workspace, methods: dict,
                  results: dict) -> None:
    """WS/eval/results.json, table.md and grid.jpg."""
    atomic_write_json(base.eval / "results.json", results)
    (base.eval / "table.md").parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(base.eval / "table.md", table_markdown(results))
    atomic_imwrite(base.eval / "grid.jpg", image_grid(cfg, scene, base, methods, results),
                   [cv2.IMWRITE_JPEG_QUALITY, 90])
    info(f"eval: wrote {base.eval / 'table.md'}, results.json and grid.jpg")


def format_or_dash(v, fmt: str = "{:.2f}") -> str:
    """``v`` formatted, or a dash when it is None."""
    return "—" if v is None else fmt.format(v)


def table_markdown(res: dict) -> str:
    budget, mask_scores = res["budget"], res["mask_scores"]
    origin = res["origin"]
    where = ("one of the held-out scenes (pipeline.scene_splits.HELDOUT_SCENES), never used for "
             "training" if res["origin_is_heldout_scene"] else
             "NOT one of pipeline.scene_splits.HELDOUT_SCENES: a trained model may have seen it")
    if res["masks"] == "gt":
        masks = "ground truth masks_gt (`--masks gt`), so no FMG mIoU is measured"
    else:
        cut = res.get("mask_threshold")
        masks = (f"FMG network (shipped weights unless --fmg-weights), probability cut "
                 f"{format_or_dash(cut, '{:g}')}; against masks_gt on "
                 f"the training views: mIoU {format_or_dash(mask_scores.get('miou'), '{:.3f}')}, "
                 f"flare IoU {format_or_dash(mask_scores.get('iou_flare'), '{:.3f}')}")
    lines = [
        f"# deflare-scene eval: {origin} with synthetic flare", "",
        f"- Scene: `{res['scene']}`, made from `{origin}`: {where}.",
        f"- Views: {len(res['train_views'])} training views (photos with flare; inputs are "
        f"scored on the {len(res['scored_input_views'])} with flare in masks_gt), "
        f"{len(res['heldout_views'])} held-out views. Cameras: ground truth for every view "
        "(no pose noise; COLMAP was not run on the flared photos).",
        f"- Masks: {masks}.",
        f"- Budget, the same for every neural variant: preset `{budget['preset']}` on "
        f"{budget['device']}, {budget['iters']} steps (paper: 50,000 fine-tuning steps after "
        f"500k pretraining), {budget['rays']} rays x {budget['samples']} samples, model depth "
        f"{budget['depth']} width {budget['width']} (paper: GNT, depth 8 width 64), sources at "
        f"{budget['source_scale']:g} resolution, {budget['eval_views']} render views, `--init "
        f"{budget['init']}` asked (what each model started from: below, from its checkpoint).",
        f"- Held-out views rendered and scored at {budget['render_scale']:g} of full size"
        f"{'' if budget['render_scale'] == 1 else ' (cut for time)'}; de-flared inputs at full "
        f"size, {'with' if budget.get('color_match', False) else 'without'} the render stage's "
        f"colour match of the fill; render fill: {budget.get('fill', 'network')}.",
        *provenance_lines(res), "",
        "| method | held-out PSNR | held-out SSIM | inputs PSNR | inputs SSIM | "
        "flare-region PSNR | targets | train s |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for method in res["methods"].values():
        heldout, inputs, train = (method.get("heldout", {}), method["inputs"],
                                  method.get("train", {}))
        cells = [format_or_dash(heldout.get("psnr")),
                 format_or_dash(heldout.get("ssim"), "{:.4f}"),
                 format_or_dash(inputs.get("psnr")),
                 format_or_dash(inputs.get("ssim"), "{:.4f}"),
                 format_or_dash(inputs.get("psnr_flare")),
                 (f"{train['targets']}/{train['views']}" if "targets" in train else "—"),
                 format_or_dash(train.get("seconds"), "{:.0f}")]
        lines.append(f"| {method['label']} | " + " | ".join(cells) + " |")
    lines += ["", "PSNR in dB, SSIM (Gaussian window, Wang et al. 2004) on [0, 1] RGB against "
              "SCENE/clean. Held-out: full renders of the held-out cameras (novel views). "
              "Inputs: the de-flared training photos as `render --path inputs` writes them "
              "(the masked region re-rendered and blended; baselines: the photo itself, or "
              "inpainted). Flare-region PSNR: only the pixels of masks_gt. Targets: the "
              "training views each fine-tune took as targets, of all (views.json's flags, "
              "select's --max-flare rule; every view without the View Sampler). Baselines have no "
              "held-out views (—). Paper (Table 1, full budget, real-scene synthetic "
              "flare): GNT 22.44 dB, GN-FR 26.18 dB / SSIM 0.8815 on held-out views.", ""]
    return "\n".join(lines)


def provenance_lines(res: dict) -> list[str]:
    """Markdown bullets: the code and machine that scored, and per neural method what its
    checkpoint says trained it."""
    prov = res.get("provenance")
    if not prov:
        return ["- Provenance: not recorded (results written before eval recorded it)."]
    code, mach = prov.get("code") or {}, prov.get("machine") or {}
    commit = (code.get("commit") or "unknown")[:12]
    n_dirty = len(code.get("dirty_files") or [])
    dirty = f" with uncommitted changes to {n_dirty} files" if code.get("dirty") else ""
    lines = [f"- Scored by commit `{commit}`{dirty}"
             f" on {mach.get('cpu')} ({mach.get('torch_threads')} torch threads, torch "
             f"{mach.get('torch')}, GPU: {(mach.get('cuda') or {}).get('name', 'none')}); "
             f"command `{prov.get('command')}`."]
    groups: dict[str, list[str]] = {}  # methods that share one model print one line
    for method in res["methods"].values():
        summary = (method.get("provenance") or {}).get("summary")
        if summary is not None:
            groups.setdefault(json.dumps(summary, sort_keys=True), []).append(method["label"])
    for key, labels in groups.items():
        summary, label = json.loads(key), " and ".join(labels)
        if not summary["from_checkpoint"]:
            lines.append(f"- {label}: its checkpoint records no provenance (written "
                         f"before finetune recorded it): start weights unknown, "
                         f"{summary['steps_done']} steps.")
            continue
        start = (f"`{summary['trained_from']}` (sha256 {summary['init_sha256'][:12]})"
                 if summary["init_sha256"] else "scratch")
        lines.append(
            f"- {label}: trained from {start}, {summary['steps_done']} steps of preset "
            f"`{summary['preset']}`, seed {summary['seed']}, "
            f"{'cached features' if summary['cached_features'] else 'end-to-end'}, on "
            f"{summary['device']}, {format_or_dash(summary['train_seconds'], '{:.0f}')} s"
            + ("" if summary["fill"] is None else f"; inputs rendered "
               f"{'with' if summary['color_match'] else 'without'} colour match, fill "
               f"{summary['fill']}")
            + f"; held-out fill {', '.join(map(str, summary['heldout_fill'])) or '—'}.")
    return lines


def caption_tile(img: np.ndarray | None, size: tuple[int, int], text: str) -> np.ndarray:
    """[h, w, 3] uint8 BGR thumbnail with a caption (grey when there is no image)."""
    w, h = size
    tile = np.full((h, w, 3), 64, np.uint8) if img is None else \
        cv2.resize(img, (w, h), interpolation=cv2.INTER_AREA)
    cv2.rectangle(tile, (0, 0), (w, 16), (0, 0, 0), -1)
    cv2.putText(tile, text[: w // 7], (3, 12), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (255, 255, 255), 1,
                cv2.LINE_AA)
    return tile


def image_grid(cfg: EvalConfig, scene: SynthScene, base: Workspace, methods: dict,
               res: dict, height: int = 180) -> np.ndarray:
    """Rows: held-out views, then the most flared inputs; columns: input, every method
    (except the input baseline), ground truth."""
    flare = {s: float(truth_mask(scene, s).mean()) for s in scene.train}
    train = sorted(flared_views(scene) or scene.train, key=lambda s: -flare[s])
    n_held = min(len(scene.heldout), max(1, cfg.grid_rows // 2))
    rows = scene.heldout[:n_held] + train[: max(0, cfg.grid_rows - n_held)]
    first_truth = read_bgr(scene.root / "clean" / f"{rows[0]}.png")
    size = (max(16, round(height * first_truth.shape[1] / first_truth.shape[0])), height)
    columns = [name for name in methods if name != "input"]
    out = []
    for stem in rows:
        held = stem in scene.heldout
        photo = None if held else read_bgr(base.image_path(stem))
        tiles = [caption_tile(photo, size, f"{stem} held-out" if held else f"{stem} input")]
        for name in columns:
            key = "heldout" if held else "inputs"
            folder = methods[name].get(key)
            score = res["methods"][name].get(key, {}).get("views", {}).get(stem, {})
            img = read_bgr(folder / f"{stem}.png") if folder is not None else None
            psnr = format_or_dash(score.get("psnr"), "{:.1f}")
            tiles.append(caption_tile(img, size, f"{name} {psnr}dB"))
        truth = read_bgr(scene.root / "clean" / f"{stem}.png")
        tiles.append(caption_tile(truth, size, "ground truth"))
        out.append(np.concatenate(tiles, 1))
    return np.concatenate(out, 0)
