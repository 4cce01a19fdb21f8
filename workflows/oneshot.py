"""The one-shot pipeline: every stage in order on one photo folder, each resumable."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from pipeline.errors import UserError
from pipeline.progress import info


@dataclass
class OneShotConfig:
    photos: Path
    """Folder of photos (only read)."""
    out: Path | None = None
    """Workspace folder; default ``<photos>.deflare`` beside the photo folder."""
    max_size: int = 1008
    """Decode: long side of the decoded images in pixels."""
    matcher: str = "auto"
    """Pose: exhaustive, sequential or auto."""
    force: bool = False
    """Rerun every stage even when its inputs did not change."""


def default_workspace(photos: Path) -> Path:
    photos = Path(photos).resolve()
    return photos.with_name(photos.name + ".deflare")


def run_all(cfg: OneShotConfig) -> Path:
    """Run the stages that exist, in order; return the workspace path."""
    from pipeline import decode, pose

    photos = Path(cfg.photos)
    if not photos.exists():
        raise UserError(f"photo folder {photos} does not exist: pass a folder of photos, "
                        "e.g. `deflare-scene ./photos`, or see `deflare-scene --help`")
    ws_path = Path(cfg.out) if cfg.out else default_workspace(photos)
    ws = decode.run(decode.DecodeConfig(max_size=cfg.max_size), photos, ws_path, force=cfg.force)
    pose.run(pose.PoseConfig(matcher=cfg.matcher), ws, force=cfg.force)
    info(f"[green]done[/green]: workspace {ws.root}")
    return ws.root
