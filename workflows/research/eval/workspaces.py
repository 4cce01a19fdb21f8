"""The evaluation workspace and its per-variant workspaces, built from a synth scene by links."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

from pipeline.cameras import Cameras, Frame
from pipeline.images import read_image
from pipeline.workspace import Workspace, atomic_imwrite, atomic_write_json, read_json
from pipeline.ws_files import write_cameras
from workflows.research.eval.config import SHARED_STAGES
from workflows.research.eval.scene import SynthScene, photo_path


def linked_paths(ws: Workspace) -> list[Path]:
    """What a variant workspace shares with the evaluation workspace (hard links): the
    outputs of ``SHARED_STAGES`` that the variant's finetune and render read."""
    return [ws.images, ws.decoded, ws.masks, ws.cameras_json, ws.views_json, ws.flare_json,
            ws.depth]



def place_photo(src: Path, dst: Path) -> None:
    """``dst`` (a .png) holds the image of ``src``: a hard link when ``src`` is a PNG, else
    a lossless PNG re-encoding."""
    if src.suffix.lower() == ".png":
        link_file(src, dst)
    elif not dst.exists():
        atomic_imwrite(dst, read_image(src, bgr=True))


def link_file(src: Path, dst: Path) -> None:
    """Make ``dst`` a hard link of ``src`` (a copy across devices), atomically."""
    if dst.exists() and os.path.samefile(src, dst):
        return
    dst.parent.mkdir(parents=True, exist_ok=True)
    tmp = dst.with_name(f".{dst.name}.link{os.getpid()}")
    tmp.unlink(missing_ok=True)
    try:
        os.link(src, tmp)
    except OSError:
        shutil.copy2(src, tmp)
    os.replace(tmp, dst)


def sync_tree(src: Path, dst: Path) -> None:
    """Mirror folder or file ``src`` at ``dst`` with hard links, its sub-folders too (e.g.
    WS/depth/frames); extra files and folders removed, hidden ones (a stage's
    intermediates) neither mirrored nor touched."""
    if src.is_file():
        link_file(src, dst)
        return
    dst.mkdir(parents=True, exist_ok=True)
    shown = [p for p in src.iterdir() if not p.name.startswith(".")]
    names = {p.name for p in shown if p.is_file()}
    folders = {p.name for p in shown if p.is_dir()}
    for name in names:
        link_file(src / name, dst / name)
    for name in folders:
        sync_tree(src / name, dst / name)
    for p in dst.iterdir():
        if p.name.startswith("."):
            continue
        if p.is_file() and p.name not in names:
            p.unlink()
        elif p.is_dir() and p.name not in folders:
            shutil.rmtree(p)


def pinhole_frame(f: Frame) -> Frame:
    """``f`` with its COLMAP camera replaced by the pinhole of its image (decoded = images)."""
    K = f.K
    cam = {"model": "PINHOLE", "width": f.width, "height": f.height,
           "params": [float(K[0, 0]), float(K[1, 1]), float(K[0, 2]), float(K[1, 2])]}
    return Frame(f.name, f.stem, K, f.width, f.height, f.c2w, f.near, f.far, cam)


def build_workspace(scene: SynthScene, out: Path, force: bool = False,
                    folder: str = "photos") -> Workspace:
    """The posed evaluation workspace: training photos (of ``folder``: ``clean`` for the
    clean ones) + ground-truth cameras."""
    ws = Workspace.create(out, scene.root / folder)
    params = {"cameras": "ground truth (synth cameras_gt.json)", "scene": str(scene.root)}
    if folder != "photos":
        params["folder"] = folder
    stage = ws.begin_stage("pose", params, [scene.root / folder, scene.root / "cameras_gt.json"],
                           force)
    if stage.skip:
        return ws
    by_stem = scene.cams.by_stem()
    frames = [pinhole_frame(by_stem[stem]) for stem in scene.train]
    for stem in scene.train:
        src = photo_path(scene.root, stem, folder)
        place_photo(src, ws.image_path(stem))
        place_photo(src, ws.decoded_path(stem))
    write_cameras(ws, Cameras(frames, scene.cams.colmap_to_world))
    ws.record_stage("decode", {"linked_from": str(scene.root / folder)}, [ws.decoded])
    stage.finish([ws.images, ws.cameras_json])
    return ws


def variant_workspace(base: Workspace, name: str) -> Workspace:
    """WS/variants/<name>: a workspace sharing base's inputs and stage records."""
    return shared_workspace(base, base.variants / name)


def shared_workspace(base: Workspace, root: Path) -> Workspace:
    """A workspace at ``root`` sharing base's ``linked_paths`` (hard links, copies across
    devices; paths base lacks are skipped) and the records of ``SHARED_STAGES`` it has:
    later stages run there without writing into ``base``."""
    ws = Workspace.create(root, base.photos_dir)
    for path in linked_paths(base):
        if path.exists():
            sync_tree(path, ws.root / path.relative_to(base.root))
    ws.copy_stage_records(base, [s for s in SHARED_STAGES if base.stage_record(s)])
    return ws


def heldout_path_json(scene: SynthScene, ws: Workspace) -> Path:
    """WS/eval/heldout_cameras.json: the held-out cameras as a JSON camera path."""
    from gnfr.paths import PathCamera, path_to_json

    by_stem = scene.cams.by_stem()
    cams = [PathCamera(stem, by_stem[stem].K, by_stem[stem].c2w, by_stem[stem].width,
                       by_stem[stem].height) for stem in scene.heldout]
    path = ws.eval / "heldout_cameras.json"
    data = path_to_json(cams)
    if not path.exists() or read_json(path) != _roundtrip(data):
        atomic_write_json(path, data)
    return path


def _roundtrip(obj):
    """``obj`` as it reads back from JSON (tuples become lists)."""
    return json.loads(json.dumps(obj))

