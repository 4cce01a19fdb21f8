"""The workspace folder: its paths (each named once), manifest bookkeeping, atomic writes.

One workspace (``WS``) per scene. The user's photo folder is only ever read; every
output lives under ``WS`` (see ``docs/design.md`` for the contract). Every path under
``WS`` is a ``Workspace`` property (or a per-view helper such as ``mask_path(stem)``);
what the files hold is read and written by ``pipeline/ws_files.py``. Each stage records
in ``WS/manifest.json`` its parameters, a digest of the inputs it read, the outputs it
wrote, package versions and timing. A stage whose parameters and input digest are
unchanged is skipped; since a stage's input digest covers the files earlier stages
wrote, rerunning an early stage makes every later one that read its outputs stale. A
stage interrupted resumes at the same parameters and inputs; the files it keeps are those
written since its first attempt at them (``Workspace.kept``; ``StageRun.since``), and a
finished stage that runs again says why (``rerun_reason``).

All writes go to a temporary name in the destination folder and are renamed into
place (``os.replace`` is atomic on POSIX), so a run killed at any moment leaves either
the old file or the new one, never half of one. Outputs made outside a stage's own run
(ground-truth cameras, linked images) are recorded with ``Workspace.record_stage``.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import re
import shutil
import time
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pipeline.errors import UserError, shell_path

SCHEMA_VERSION = 1
MANIFEST = "manifest.json"
WS_SUFFIX = ".deflare"
"""A workspace's default name: ``<photos>.deflare`` beside the photo folder."""
MODEL_FILE = "gnfr.safetensors"
"""File name of the fine-tuned weights in WS/model (``Workspace.model_file``)."""
TRAIN_STATE_FILE = "train_state.pt"
"""Training state in WS/model (``Workspace.train_state``)."""
METRICS_FILE = "metrics.jsonl"
"""Metric lines in WS/model (``Workspace.metrics_jsonl``)."""
UNSEEN_FILE = "unseen.json"
"""Per-target unseen fractions in WS/model (``Workspace.unseen_json``)."""
PATH_CAMERAS_FILE = "cameras.json"
"""The cameras of a rendered path, in its folder ``WS/renders/<path>/``."""


# --------------------------------------------------------------------------- atomic writes
def _tmp_name(path: Path) -> Path:
    # keep the real suffix last so writers that pick a format by extension still work
    return path.with_name(f".{path.stem}.tmp{os.getpid()}{path.suffix}")


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` on success.

    On an exception the temporary file is removed and ``path`` is left untouched.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = _tmp_name(path)
    try:
        yield tmp
        if tmp.is_dir():
            if path.exists():
                trash = path.with_name(f".{path.name}.old{os.getpid()}")
                os.replace(path, trash)
                os.replace(tmp, path)
                shutil.rmtree(trash, ignore_errors=True)
            else:
                os.replace(tmp, path)
        else:
            if not tmp.exists():
                raise RuntimeError(f"writer produced no file at {tmp}")
            os.replace(tmp, path)
    finally:
        if tmp.is_dir():
            shutil.rmtree(tmp, ignore_errors=True)
        elif tmp.exists():
            tmp.unlink()


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> Path:
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)


def atomic_write_text(path: str | os.PathLike, text: str) -> Path:
    return atomic_write_bytes(path, text.encode("utf-8"))


def atomic_write_json(path: str | os.PathLike, obj: Any) -> Path:
    return atomic_write_text(path, json.dumps(obj, indent=2, sort_keys=False) + "\n")


def atomic_imwrite(path: str | os.PathLike, image, params: list[int] | None = None) -> Path:
    """Write an image with OpenCV atomically (format from the suffix)."""
    import cv2

    with atomic_path(path) as tmp:
        if not cv2.imwrite(str(tmp), image, params or []):
            raise OSError(f"could not write image {path}")
    return Path(path)


def read_json(path: str | os.PathLike,
              fix: str = "delete it and rerun the stage that writes it") -> Any:
    """The parsed JSON file ``path``; a missing or broken file is one UserError line, a
    broken one saying what to do (``fix``: for a workspace file, write it again; a file the
    user wrote, such as a camera path, is mended, never deleted)."""
    path = Path(path)
    try:
        return json.loads(path.read_text())
    except FileNotFoundError:
        raise UserError(f"{path} is missing: run the stage that writes it first") from None
    except json.JSONDecodeError as e:
        raise UserError(f"{path} is not valid JSON ({e.msg} at line {e.lineno}); "
                        f"{fix}") from None


# --------------------------------------------------------------------------- digests
def file_digest(path: Path) -> str:
    h = hashlib.blake2b(digest_size=16)
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def digest_paths(paths: Iterable[str | os.PathLike], root: Path | None = None) -> str:
    """One digest over files and folders (recursively, by relative name and content).

    Hidden files (temporary writes, ``.DS_Store``) are ignored. A missing path counts
    as a distinct state, so creating it later changes the digest.
    """
    h = hashlib.blake2b(digest_size=16)
    for p in sorted(Path(x) for x in paths):
        label = str(p.relative_to(root)) if root and p.is_relative_to(root) else str(p)
        if p.is_dir():
            for f in sorted(p.rglob("*")):
                rel = f.relative_to(p)
                if f.is_file() and not any(part.startswith(".") for part in rel.parts):
                    h.update(f"{label}/{rel}\0{file_digest(f)}\0".encode())
        elif p.is_file():
            h.update(f"{label}\0{file_digest(p)}\0".encode())
        else:
            h.update(f"{label}\0<missing>\0".encode())
    return h.hexdigest()


def package_versions(*names: str) -> dict[str, str]:
    from importlib import metadata

    out = {}
    for name in ("deflare-scene", *names):
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out


# --------------------------------------------------------------------------- workspace
def default_workspace(photos: str | os.PathLike) -> Path:
    """``<photos>.deflare`` beside the photo folder: the workspace when no --out is given."""
    photos = Path(photos).resolve()
    return photos.with_name(photos.name + WS_SUFFIX)


def enclosing_workspace(path: str | os.PathLike) -> tuple[Path, Path | None] | None:
    """(root, its photo folder) of the deflare-scene workspace that ``path`` is or lies in
    (a ``manifest.json`` naming a photo folder, in ``path`` or a folder above it), else
    None: a workspace, or its ``decoded``/``images`` folder, passed where photos belong."""
    path = Path(path).resolve()
    for folder in (path, *path.parents):
        man = folder / MANIFEST
        if not man.is_file():
            continue
        try:
            data = json.loads(man.read_text())
        except (OSError, ValueError):
            continue
        if isinstance(data, dict) and isinstance(data.get("photos"), str) and "stages" in data:
            return folder, Path(data["photos"])  # else another program's manifest.json
    return None


_ABSENT = object()


def same_params(previous, current, defaults=None) -> bool:
    """True when a stage's recorded parameters ``previous`` and its ``current`` ones are
    the same, where a key on one side only (an option added to, or dropped from, the stage
    since the record was written) matches when its value there is its entry in
    ``defaults`` (nested like the parameters). So an option added with the old behaviour as
    its default leaves every finished stage up to date while it stays at that default, and
    makes the stage run again when it is set; no manifest needs migrating. Both sides are
    JSON values (``begin_stage`` round-trips them)."""
    return not changed_params(previous, current, defaults)


def changed_params(previous, current, defaults=None, prefix: str = "") -> list[tuple]:
    """The parameters that differ, as ``same_params`` compares them: (dotted key, recorded
    value, current value) for each, a key absent on one side given as its default (or
    None); empty when they are the same."""
    if not (isinstance(previous, dict) and isinstance(current, dict)):
        return [] if previous == current else [(prefix or "parameters", previous, current)]
    defaults = defaults if isinstance(defaults, dict) else {}
    changed = []
    for key in sorted(previous.keys() | current.keys()):
        old, new = previous.get(key, _ABSENT), current.get(key, _ABSENT)
        name = f"{prefix}.{key}" if prefix else key
        if old is _ABSENT or new is _ABSENT:
            value = new if old is _ABSENT else old
            if key not in defaults or value != defaults[key]:
                old, new = (defaults.get(key) if v is _ABSENT else v for v in (old, new))
                changed.append((name, old, new))
        else:
            changed += changed_params(old, new, defaults.get(key), name)
    return changed


def rerun_reason(previous: dict, params: dict, digest: str, defaults: dict | None,
                 outputs_ok: bool) -> str:
    """Why a finished stage runs again, in words: its changed settings (up to three, with
    their old and new values), changed inputs or a missing output."""
    changed = changed_params(previous.get("params"), params, defaults)
    if changed:
        shown = ", ".join(f"{k} {json.dumps(a)} -> {json.dumps(b)}" for k, a, b in changed[:3])
        more = f" and {len(changed) - 3} more" if len(changed) > 3 else ""
        return f"its settings changed ({shown}{more})"
    if previous.get("inputs_digest") != digest:
        return "its inputs changed since it ran"
    return "an output it wrote is missing" if not outputs_ok else "it is asked to"


@dataclass
class StageRun:
    """Bookkeeping of one stage execution; returned by :meth:`Workspace.begin_stage`."""

    ws: Workspace
    name: str
    params: dict
    inputs_digest: str
    skip: bool
    previous: dict = field(default_factory=dict)
    force: bool = False
    started: float = field(default_factory=time.time)
    defaults: dict = field(default_factory=dict)
    """The parameters' defaults (``same_params``)."""
    resumes: bool = False
    """The previous attempt had these parameters and inputs, and no ``force``: its per-file
    outputs may be kept (``Workspace.resumable``)."""
    since: float = 0.0
    """When the attempts at these parameters and inputs began (the manifest's mtime then):
    a file older than that is an earlier run's, of other settings (``Workspace.kept``)."""

    @property
    def outputs(self) -> list[Path]:
        return [self.ws.root / p for p in self.previous.get("outputs", [])]

    def finish(self, outputs: Iterable[str | os.PathLike], extra: dict | None = None,
               versions: Iterable[str] = ()) -> list[Path]:
        outs = [Path(p) for p in outputs]
        rel = sorted(str(p.relative_to(self.ws.root)) if p.is_absolute() else str(p)
                     for p in outs)
        record = {
            "status": "complete",
            "params": self.params,
            "inputs_digest": self.inputs_digest,
            "outputs": rel,
            "versions": package_versions(*versions),
            "started": time.strftime("%Y-%m-%dT%H:%M:%S", time.localtime(self.started)),
            "seconds": round(time.time() - self.started, 3),
        }
        if extra:
            record.update(extra)
        self.ws.update_manifest(self.name, record)
        return [self.ws.root / r for r in rel]


def scene_folder_name(photos: Path) -> str:
    """The scene's name for a photo folder: its own name, or its parent's when it is a
    scene's ``images`` or ``images_<N>`` folder (COLMAP's and LLFF's layouts), so that
    ``lund/images`` makes ``lund.mp4``, not ``images.mp4``."""
    if re.fullmatch(r"images(_\d+)?", photos.name) and photos.parent.name:
        return photos.parent.name
    return photos.name


class Workspace:
    """A scene's working folder (``WS``); see the module docstring and docs/design.md."""

    def __init__(self, root: str | os.PathLike):
        self.root = Path(root).resolve()

    # layout: every path of the contract (docs/design.md), named once ------
    @property
    def manifest_path(self) -> Path:
        return self.root / MANIFEST

    decoded = property(lambda self: self.root / "decoded")
    """WS/decoded/<stem>.png: 8-bit sRGB photos (decode)."""
    linear = property(lambda self: self.root / "linear")
    """WS/linear/<stem>.tiff: 16-bit linear camera RGB of raw photos (decode)."""
    colmap = property(lambda self: self.root / "colmap")
    """WS/colmap/: database.db, sparse/0/, report.json (pose)."""
    colmap_db = property(lambda self: self.root / "colmap" / "database.db")
    colmap_model = property(lambda self: self.root / "colmap" / "sparse" / "0")
    colmap_report = property(lambda self: self.root / "colmap" / "report.json")
    images = property(lambda self: self.root / "images")
    """WS/images/<stem>.png: undistorted pinhole images, what the model reads (pose)."""
    cameras_json = property(lambda self: self.root / "cameras.json")
    scene_glb = property(lambda self: self.root / "scene.glb")
    points_ply = property(lambda self: self.root / "points.ply")
    """WS/points.ply: the depth maps' points, coloured (export)."""
    masks = property(lambda self: self.root / "masks")
    """WS/masks/<stem>.png: 255 = flare (mask); read with pipeline.ws_files.read_mask."""
    flare_json = property(lambda self: self.root / "flare.json")
    masks_overview = property(lambda self: self.root / "masks_overview.jpg")
    depth = property(lambda self: self.root / "depth")
    """WS/depth/<stem>.npz: depth and confidence per view (depth)."""
    depth_frames = property(lambda self: self.root / "depth" / "frames")
    """WS/depth/frames/<stem>.npz: the maps the novel frames warp the photos through, the
    sweep's costs aggregated (depth ``--frames-sgm``); absent: the novel frames use WS/depth."""
    sweeps = property(lambda self: self.root / ".sweeps")
    """WS/.sweeps/<stem>.npz and .key: the mask stage's plane sweeps, which the depth stage
    takes where their key matches (pipeline.depth.sweep_views) and then removes."""
    views_json = property(lambda self: self.root / "views.json")
    model = property(lambda self: self.root / "model")
    """WS/model/: the fine-tuned GN-FR and its training state (finetune)."""
    model_file = property(lambda self: self.root / "model" / MODEL_FILE)
    """WS/model/gnfr.safetensors: the weights finetune writes and render reads."""
    train_state = property(lambda self: self.root / "model" / TRAIN_STATE_FILE)
    metrics_jsonl = property(lambda self: self.root / "model" / METRICS_FILE)
    unseen_json = property(lambda self: self.root / "model" / UNSEEN_FILE)
    deflared = property(lambda self: self.root / "deflared")
    """WS/deflared/<stem>.png: render --path inputs."""
    deflared_full = property(lambda self: self.root / "deflared_full")
    """WS/deflared_full/<stem>.*: render --full-res."""
    renders = property(lambda self: self.root / "renders")
    """WS/renders/<path>/: renders of a named or JSON camera path."""
    transforms_json = property(lambda self: self.root / "transforms.json")
    masks_nerfstudio = property(lambda self: self.root / "masks_nerfstudio")
    """WS/masks_nerfstudio/<stem>.png: export's masks for nerfstudio, 0 = flare (ignore)."""
    eval = property(lambda self: self.root / "eval")
    """WS/eval/: table.md, results.json, grid.jpg (eval)."""
    variants = property(lambda self: self.root / "variants")
    """WS/variants/<name>/: eval's per-variant workspaces."""
    baselines = property(lambda self: self.root / "baselines")
    """WS/baselines/<name>/: eval's baseline outputs."""

    @property
    def video(self) -> Path:
        """WS/<scene>.mp4 (export): the video of the default path, interpolate."""
        return self.video_of("interpolate")

    def video_of(self, path: str) -> Path:
        """The video export writes of a rendered path: WS/<scene>.mp4 for interpolate (the
        default), WS/<scene>_<path>.mp4 for any other, so a second path's video does not
        replace the first's."""
        name = Path(path).stem
        suffix = "" if name == "interpolate" else f"_{name}"
        return self.root / f"{self.scene_name}{suffix}.mp4"

    @property
    def compare_video(self) -> Path:
        """WS/<scene>_compare.mp4 (export)."""
        return self.root / f"{self.scene_name}_compare.mp4"

    @property
    def compare_sheet(self) -> Path:
        """WS/<scene>_compare.jpg (export)."""
        return self.root / f"{self.scene_name}_compare.jpg"

    # per-view files ---------------------------------------------------------
    def decoded_path(self, stem: str) -> Path:
        return self.decoded / f"{stem}.png"

    def linear_path(self, stem: str) -> Path:
        return self.linear / f"{stem}.tiff"

    def image_path(self, stem: str) -> Path:
        return self.images / f"{stem}.png"

    def mask_path(self, stem: str) -> Path:
        return self.masks / f"{stem}.png"

    def depth_inputs(self, frames: bool = False) -> list[Path]:
        """What a stage that reads the depth maps names among its inputs: the files of
        WS/depth/<stem>.npz (with ``frames`` also the novel frames' WS/depth/frames), so the
        novel frames' maps changing leaves the stages that never read them up to date; the
        folder itself while it holds no map (a missing folder is a state of its own). For a
        workspace without WS/depth/frames the digest is the folder's, as before."""
        maps = sorted(self.depth.glob("*.npz"))
        if frames and self.depth_frames.is_dir():
            maps.append(self.depth_frames)
        return maps or [self.depth]

    def depth_path(self, stem: str, frames: bool = False) -> Path:
        """WS/depth/<stem>.npz, or with ``frames`` WS/depth/frames/<stem>.npz."""
        return (self.depth_frames if frames else self.depth) / f"{stem}.npz"

    def deflared_path(self, stem: str) -> Path:
        return self.deflared / f"{stem}.png"

    def deflared_full_path(self, stem: str, suffix: str) -> Path:
        """WS/deflared_full/<stem><suffix> (``.jpg``, ``.png`` or ``.tiff`` by the photo)."""
        return self.deflared_full / f"{stem}{suffix}"

    def masks_nerfstudio_path(self, stem: str) -> Path:
        return self.masks_nerfstudio / f"{stem}.png"

    def render_dir(self, path: str) -> Path:
        """WS/renders/<path>/ of a named path or of a camera-path FILE.json (its stem)."""
        return self.renders / Path(path).stem

    def rerun(self, stage: str) -> str:
        """What to tell a user whose file from ``stage`` is missing or broken."""
        return f"rerun `deflare-scene {stage} {shell_path(self.root)} --force`"

    @property
    def scene_name(self) -> str:
        """``<scene>`` in the contract: the photo folder's name, or its parent's when the
        folder has a layout name (``images``, ``images_4``: COLMAP's and LLFF's scene/images
        folders, ``scene_folder_name``)."""
        photos = self.manifest().get("photos")
        if photos:
            return scene_folder_name(Path(photos))
        name = self.root.name
        return name.removesuffix(WS_SUFFIX)

    @property
    def photos_dir(self) -> Path | None:
        photos = self.manifest().get("photos")
        return Path(photos) if photos else None

    # creation -------------------------------------------------------------
    @classmethod
    def create(cls, root: str | os.PathLike, photos: str | os.PathLike) -> Workspace:
        """Create (or reopen) the workspace for a photo folder."""
        root, photos = Path(root).resolve(), Path(photos).resolve()
        if root == photos or root.is_relative_to(photos):
            raise UserError(f"output folder {root} is inside the photo folder {photos}: "
                            "choose an --out outside it (the photo folder is never written)")
        if root.exists() and not root.is_dir():
            raise UserError(f"{root} exists and is not a folder: choose another --out")
        if root.is_dir() and any(root.iterdir()) and not (root / MANIFEST).exists():
            raise UserError(f"{root} exists, is not empty and is not a deflare-scene "
                            "workspace: choose another --out or empty it")
        ws = cls(root)
        try:
            root.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise UserError(f"cannot create the output folder {root} ({e.strerror}): choose an "
                            "--out on a disk you can write to") from None
        man = ws.manifest() if ws.manifest_path.exists() else {}
        recorded = man.get("photos")
        if recorded and Path(recorded) != photos:
            if Path(recorded).exists():
                raise UserError(f"workspace {root} was made from {recorded}, not {photos}: "
                                "choose another --out")
            from pipeline.progress import warn  # the photos were moved: follow them

            warn(f"workspace {root} was made from {recorded}, which is no longer there: it "
                 f"reads {photos} from now on (a stage whose photos changed runs again)")
        man.setdefault("schema", SCHEMA_VERSION)
        man["photos"] = str(photos)
        man.setdefault("stages", {})
        atomic_write_json(ws.manifest_path, man)
        return ws

    @classmethod
    def open(cls, root: str | os.PathLike) -> Workspace:
        """Open an existing workspace; a clear error if ``root`` is not one."""
        root = Path(root)
        if not root.exists():
            raise UserError(f"workspace {root} does not exist: create it with "
                            f"`deflare-scene decode PHOTOS --out {shell_path(root)}`")
        if not (root / MANIFEST).is_file():
            raise UserError(f"{root} is not a deflare-scene workspace (no {MANIFEST}): create "
                            f"one with `deflare-scene decode PHOTOS --out {shell_path(root)}`")
        return cls(root)

    # manifest -------------------------------------------------------------
    def manifest(self) -> dict:
        if not self.manifest_path.exists():
            return {"schema": SCHEMA_VERSION, "stages": {}}
        man = read_json(self.manifest_path)
        if man.get("schema", 0) > SCHEMA_VERSION:
            raise UserError(f"{self.manifest_path} was written by a newer deflare-scene "
                            f"(schema {man['schema']}): upgrade deflare-scene")
        man.setdefault("stages", {})
        return man

    def update_manifest(self, stage: str, record: dict | None) -> None:
        man = self.manifest()
        if record is None:
            man["stages"].pop(stage, None)
        else:
            man["stages"][stage] = record
        atomic_write_json(self.manifest_path, man)

    def stage_record(self, stage: str) -> dict:
        return self.manifest()["stages"].get(stage, {})

    STAGE_FACTS = ("seconds", "status", "sweeps_from_mask_stage")
    """What :meth:`stage_summary` keeps of each stage's record."""

    def stage_summary(self) -> dict[str, dict]:
        """{stage: its record's ``STAGE_FACTS`` (those it has; seconds and status always)}:
        what a benchmark reports of a finished run."""
        return {name: {k: rec.get(k) for k in self.STAGE_FACTS
                       if k in ("seconds", "status") or k in rec}
                for name, rec in self.manifest()["stages"].items()}

    def record_stage(self, name: str, params: dict, outputs: Iterable[str | os.PathLike],
                     inputs: Iterable[str | os.PathLike] = (), extra: dict | None = None
                     ) -> list[Path]:
        """Record stage ``name`` as complete with ``outputs`` that were produced outside the
        stage's own ``run()`` (ground-truth cameras, images linked or written by a tool).

        The record has the shape a real run leaves (params, inputs digest, outputs,
        versions, timing), so later stages' ``require`` and staleness checks treat it alike.
        The one way to write such a record.
        """
        return self.begin_stage(name, params, inputs, force=True).finish(outputs, extra)

    def copy_stage_records(self, other: Workspace, stages: Iterable[str]) -> None:
        """Take ``other``'s manifest records of ``stages`` (a workspace sharing its files)."""
        for stage in stages:
            self.update_manifest(stage, other.stage_record(stage))

    def require(self, *stages: str) -> None:
        """Raise a clear error unless every named stage has completed."""
        for s in stages:
            if self.stage_record(s).get("status") != "complete":
                raise UserError(f"{self.root}: stage '{s}' has not run yet: run "
                                f"`deflare-scene {s} {shell_path(self.root)}` first")

    def begin_stage(self, name: str, params: dict, inputs: Iterable[str | os.PathLike],
                    force: bool = False, defaults: dict | None = None) -> StageRun:
        """Start a stage: digest its inputs and decide whether it can be skipped.

        ``params`` must be JSON-serialisable. The stage is skipped when its previous run
        completed with the same parameters (``same_params`` with ``defaults``: a parameter
        the previous record lacks matches at its default) and input digest and all its
        outputs still exist. Otherwise it is marked running; outputs of a previous
        interrupted run with the same parameters may be reused file by file by the stage.
        """
        params = json.loads(json.dumps(params, default=str))
        defaults = json.loads(json.dumps(defaults or {}, default=str))
        digest = digest_paths(inputs, self.root)
        prev = self.stage_record(name)
        outputs_ok = all((self.root / p).exists() for p in prev.get("outputs", []))
        resumes = (not force and same_params(prev.get("params"), params, defaults)
                   and prev.get("inputs_digest") == digest)
        skip = resumes and prev.get("status") == "complete" and outputs_ok
        if not skip and not force and prev.get("status") == "complete":
            from pipeline.progress import info

            info(f"{name}: running again: "
                 f"{rerun_reason(prev, params, digest, defaults, outputs_ok)}")
        # the first attempt at these settings and inputs: files older than it are an
        # earlier run's (a record without it: its files are all of these settings)
        since = float(prev.get("since", 0.0)) if resumes else None
        if not skip:
            record = {"status": "running", "params": params, "inputs_digest": digest,
                      "started": time.strftime("%Y-%m-%dT%H:%M:%S")}
            if since is None:  # stamped by the file system's clock, which stamps the files
                self.update_manifest(name, record)
                since = self.manifest_path.stat().st_mtime
            self.update_manifest(name, {**record, "since": since})
        return StageRun(self, name, params, digest, skip, prev, force, defaults=defaults,
                        since=since or 0.0, resumes=resumes)

    def kept(self, run: StageRun, path: Path) -> bool:
        """Whether the file ``path`` may be kept as ``run``'s output: the run resumes
        (``resumable``) and the file was written since its attempts began, not by an
        earlier run of other settings that an interrupted attempt had not yet replaced."""
        return (self.resumable(run) and path.exists()
                and path.stat().st_mtime >= run.since)

    def resumable(self, run: StageRun) -> bool:
        """True when per-file outputs left by an interrupted run can be kept.

        That is the case when the previous attempt had the same parameters and inputs
        (``StageRun.resumes``, decided once by ``begin_stage``).
        """
        return run.resumes
