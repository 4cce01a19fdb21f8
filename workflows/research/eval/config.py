"""The options of `deflare-scene eval` and the methods it compares (neural variants, baselines)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from pipeline.errors import UserError

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
    """Folder written by `deflare-scene synth`."""
    out: Path | None = None
    """Evaluation workspace (default SCENE/eval.ws)."""
    variants: tuple[str, ...] = ALL_VARIANTS
    """Methods to score: gnfr, gnt, no_ps, no_vs, no_ml, input, inpaint, photos."""
    masks: str = "fmg"
    """fmg (shipped FMG weights, or ``fmg_weights``) | gt (SCENE/masks_gt)."""
    fmg_weights: Path | None = None
    """FMG weights for --masks fmg (default: the shipped ones)."""
    preset: str = "auto"
    """Training preset of every neural variant (auto: paper on CUDA, quick on CPU)."""
    iters: int | None = None
    """Override the preset's steps (the same for every variant)."""
    rays: int | None = None
    """Override rays per step."""
    samples: int | None = None
    """Override samples per ray (training and rendering)."""
    views: int | None = None
    """Override the number of source views."""
    init: str = "auto"
    """Weights to start from: auto | scratch | FILE.safetensors (as finetune --init)."""
    render_scale: float = 0.5
    """Held-out views are rendered (and scored) at this fraction of their size."""
    device: str = "auto"
    """auto | cpu | cuda."""
    seed: int = 0
    """Seed of every variant's training."""
    color_match: bool = True
    """De-flared inputs with the render stage's colour match of the fill (as the product
    writes them); false scores the raw fill blended in."""
    fill: str = "hybrid"
    """Render fill of the neural variants (render --fill): hybrid (photos warped by depth
    where they agree, the network elsewhere) | network (the network everywhere)."""
    grid_rows: int = 4
    """Views (rows) in grid.jpg: held-out views first, then the most flared inputs."""
    force: bool = False
    """Redo every stage."""
    finetune_extra: dict = field(default_factory=dict)
    """Extra FinetuneConfig fields (tests, experiments)."""



def parse_variants(text: str) -> tuple[str, ...]:
    names = tuple(v.strip() for v in text.split(",") if v.strip())
    bad = [v for v in names if v not in ALL_VARIANTS]
    if bad or not names:
        raise UserError(f"--variants {text!r}: unknown {', '.join(bad) or '(empty)'}; choose "
                        f"from {','.join(ALL_VARIANTS)}")
    return names

