"""The options of `deflare-scene eval` and the methods it compares (neural variants, baselines)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from pipeline.options import option

NEURAL = {
    "gnfr": {"point_sampler": True, "view_sampler": True, "mask_loss": True},
    "gnt": {"point_sampler": False, "view_sampler": False, "mask_loss": False},
    "no_ps": {"point_sampler": False, "view_sampler": True, "mask_loss": True},
    "no_vs": {"point_sampler": True, "view_sampler": False, "mask_loss": True},
    "no_ml": {"point_sampler": True, "view_sampler": True, "mask_loss": False},
}
"""Neural variants: which of GN-FR's three parts each keeps."""
BASELINES = ("input", "inpaint", "photos")
ALL_VARIANTS = (*NEURAL, *BASELINES)
LABELS = {"gnfr": "GN-FR", "gnt": "GNT (all GN-FR parts off)",
          "no_ps": "GN-FR w/o Point Sampler", "no_vs": "GN-FR w/o View Sampler",
          "no_ml": "GN-FR w/o masking loss", "input": "flared input (no removal)",
          "inpaint": "inpainting of the mask (OpenCV Telea)",
          "photos": "photos warped by plane-sweep depth, no network (Telea where none agree)"}
SHARED_STAGES = ("decode", "pose", "mask", "depth", "select")
"""Stages whose outputs a variant workspace shares with the evaluation workspace."""


@dataclass
class EvalConfig:
    """Options of `deflare-scene eval`."""

    scene: Path
    """Folder written by `deflare-scene synth` (use a scene of TEST_SCENES: fern, kermit or
    cyprus)."""
    out: Path | None = None
    """Evaluation workspace (default SCENE/eval.ws); results in OUT/eval/."""
    variants: tuple[str, ...] = option(
        ("gnfr", "gnt", "no_ps", "no_vs", "no_ml", "input", "inpaint", "photos"),
        choices=("gnfr", "gnt", "no_ps", "no_vs", "no_ml", "input", "inpaint", "photos"))
    """Comma-separated methods: gnfr, gnt (all GN-FR parts off), no_ps, no_vs, no_ml (single
    ablations), input (flared photo), inpaint (OpenCV Telea), photos (warped by depth, no
    network)."""
    masks: str = option("fmg", choices=("fmg", "gt"))
    """fmg (FMG network: the shipped weights, or ``fmg_weights``) | gt (SCENE/masks_gt)."""
    fmg_weights: Path | None = None
    """FMG weights for --masks fmg (default: the shipped ones)."""
    preset: str = option("auto", choices=("auto", "paper", "quick", "tiny"))
    """Training preset of every neural variant: auto (paper on CUDA, quick on CPU) | quick |
    paper | tiny (smoke tests only)."""
    iters: int | None = option(None, ge=1)
    """Override the preset's steps (the same for every variant)."""
    rays: int | None = option(None, ge=1)
    """Override rays per step."""
    samples: int | None = option(None, ge=1)
    """Override samples per ray (training and rendering)."""
    views: int | None = option(None, ge=1)
    """Override the number of source views."""
    init: str = option("auto", choices=("auto", "scratch"), suffix=".safetensors")
    """Weights to start from: auto | scratch | FILE.safetensors (as finetune --init)."""
    render_scale: float = option(0.5, gt=0, le=1)
    """Held-out views are rendered (and scored) at this fraction of full size (smaller is
    faster)."""
    device: str = option("auto", device=True)
    """auto | cpu | cuda | cuda:N."""
    seed: int = option(0, ge=0)
    """Training seed of every variant."""
    color_match: bool = True
    """De-flared inputs with the render stage's colour match of the fill (as the product
    writes them); --no-color-match scores the raw fill blended in."""
    fill: str = option("hybrid", choices=("hybrid", "network"))
    """Render fill of the neural variants (render --fill): hybrid (photos warped by depth
    where they agree, the network elsewhere) | network (the network everywhere)."""
    grid_rows: int = option(4, ge=1)
    """Views (rows) shown in grid.jpg: held-out views first, then the most flared inputs."""
    force: bool = False
    """Redo every stage."""
    finetune_extra: dict = field(default_factory=dict)
    """Extra FinetuneConfig fields (Python API: tests, experiments)."""
