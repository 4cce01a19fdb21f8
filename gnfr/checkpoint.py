"""Checkpoints: GN-FR weights as safetensors and the training state beside them.

The weights carry the architecture in their metadata; the training state (optimizer, RNG,
step) is a plain dict of tensors loaded with ``torch.load(weights_only=True)``.
"""

from __future__ import annotations

import dataclasses
import json
import os
from pathlib import Path

import torch
from safetensors import safe_open
from safetensors.torch import save_file

from gnfr.model import GNFR, GNFRConfig

FORMAT = "gnfr-1"


class CheckpointError(ValueError):
    """A weight file that is missing, not a GN-FR checkpoint, or of another architecture."""


def save_model(path: str | os.PathLike, model: GNFR, meta: dict | None = None,
               dtype: torch.dtype | None = None) -> Path:
    """Write the model's weights (optionally cast, e.g. fp16 for shipping) to ``path``
    (written to a temporary name and renamed). ``meta`` values are stored as JSON strings."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tensors = {k: (v.to(dtype) if dtype and v.is_floating_point() else v).detach().cpu()
               .contiguous() for k, v in model.state_dict().items()}
    metadata = {"format": FORMAT, "gnfr_config": model.config.to_json()}
    metadata.update({k: json.dumps(v) for k, v in (meta or {}).items()})
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    save_file(tensors, str(tmp), metadata=metadata)
    os.replace(tmp, path)
    return path


def replace_metadata(path: str | os.PathLike, updates: dict[str, str]) -> Path:
    """Rewrite a safetensors file with its raw string metadata updated by ``updates`` and
    the tensors unchanged (temporary name, then rename). GN-FR extra metadata values are
    JSON strings (``json.dumps``); the FMG's are plain strings."""
    from safetensors.torch import load_file

    path = Path(path)
    with safe_open(str(path), framework="pt") as f:
        meta = dict(f.metadata() or {})
    meta.update(updates)
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    save_file(load_file(str(path)), str(tmp), metadata=meta)
    os.replace(tmp, path)
    return path


def read_metadata(path: str | os.PathLike) -> tuple[GNFRConfig, dict]:
    """(architecture, extra metadata decoded from JSON) of a checkpoint."""
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"{path} does not exist")
    try:
        with safe_open(str(path), framework="pt") as f:
            meta = dict(f.metadata() or {})
    except Exception as e:  # safetensors raises several error types for bad files
        raise CheckpointError(f"{path} is not a safetensors file ({e})") from None
    if meta.get("format") != FORMAT or "gnfr_config" not in meta:
        raise CheckpointError(f"{path} is not a GN-FR checkpoint (no gnfr_config metadata)")
    cfg = GNFRConfig.from_json(meta.pop("gnfr_config"))
    meta.pop("format")
    return cfg, {k: json.loads(v) for k, v in meta.items()}


def load_weights(model: GNFR, path: str | os.PathLike) -> dict:
    """Load weights into ``model``; CheckpointError when the architecture differs (a file
    without the flare flag loads into a model with it, the flag's input weights at zero:
    ``GNFRConfig.grown_from``). Returns the extra metadata."""
    cfg, meta = read_metadata(path)
    if not model.config.grown_from(cfg):
        a, b = dataclasses.asdict(cfg.architecture()), dataclasses.asdict(
            model.config.architecture())
        diff = ", ".join(f"{k} {a[k]} in the file, {b[k]} in the model" for k in a
                         if a[k] != b[k])
        raise CheckpointError(f"{path} holds a different architecture ({diff})")
    from safetensors.torch import load_file

    state = load_file(str(path))
    if cfg.architecture() != model.config.architecture():
        state = model.grown_state(state)
    own = model.state_dict()
    model.load_state_dict({k: v.to(own[k].dtype) for k, v in state.items()})
    return meta


def load_model(path: str | os.PathLike, device="cpu") -> GNFR:
    """Rebuild a model from a checkpoint alone (architecture from its metadata), in eval
    mode on ``device``."""
    cfg, _ = read_metadata(path)
    model = GNFR(cfg)
    load_weights(model, path)
    return model.to(device).eval()


def save_train_state(path: str | os.PathLike, state: dict) -> Path:
    """Save a dict of tensors / numbers / strings / nested dicts and lists (optimizer
    state_dict, RNG states, step) atomically."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    torch.save(state, tmp)
    os.replace(tmp, path)
    return path


def load_train_state(path: str | os.PathLike) -> dict:
    return torch.load(path, map_location="cpu", weights_only=True)
