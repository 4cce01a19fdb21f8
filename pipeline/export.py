"""Stage `export`: video, comparisons, scene.glb with the path, nerfstudio transforms.json.

Writes
- ``WS/<scene>.mp4`` (``WS/<scene>_<path>.mp4`` for a path other than interpolate):
  H.264 (yuv420p) of the frames of a rendered path (default
  ``interpolate``), see pipeline/video.py;
- ``WS/<scene>_compare.mp4`` and ``WS/<scene>_compare.jpg``: each input photo beside its
  de-flared version (``WS/decoded`` | ``WS/deflared``), as a video and a contact sheet;
- ``WS/scene.glb``: sparse points and input cameras plus the rendered camera path;
- ``WS/transforms.json`` and ``WS/masks_nerfstudio/<stem>.png``: the poses and flare masks
  in nerfstudio's format (see :func:`nerfstudio_transforms` for the choices made);
- ``WS/points.ply``: the depth maps' points (WS/depth) coloured by the photos, a binary PLY
  in the same world frame (MeshLab, CloudCompare, Blender, Open3D read it).
Each output is skipped when its inputs are missing, with a message saying what to run.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from pipeline.camera_models import CameraModel
from pipeline.cameras import Cameras, Frame
from pipeline.errors import UserError, shell_path
from pipeline.images import image_size, read_image
from pipeline.options import option, validate
from pipeline.progress import info, track, warn
from pipeline.render import decoded_camera, flare_mask_in, path_cameras, rendered_frames
from pipeline.workspace import Workspace, atomic_imwrite, atomic_write_json
from pipeline.ws_files import has_masks, read_cameras, read_decoded, read_mask

CV_GL = np.diag([1.0, -1.0, -1.0, 1.0])  # OpenCV <-> OpenGL camera axes (flip y and z)


@dataclass
class ExportConfig:
    """Options of the export stage."""

    path: str = "interpolate"
    """Rendered path whose frames make the video: a folder name under WS/renders."""
    fps: float = option(24.0, gt=0)
    """Frame rate of the videos."""
    crf: int = option(18, ge=0, le=51)
    """H.264 quality: 0 lossless .. 51 worst; 18 is visually lossless, 23 x264's default."""
    compare: bool = True
    """Write the input vs de-flared comparison video and contact sheet."""
    glb: bool = True
    """Rewrite WS/scene.glb with the rendered camera path."""
    transforms: bool = True
    """Write WS/transforms.json and WS/masks_nerfstudio/ (nerfstudio format)."""
    points: bool = True
    """Write WS/points.ply: every view's depth map (WS/depth) as coloured points."""
    max_points: int = option(2_000_000, ge=1)
    """At most this many points in WS/points.ply (an even sample of them when more)."""


def run(cfg: ExportConfig, ws: Workspace, force: bool = False) -> list[Path]:
    """Export the rendered path ``cfg.path`` and what else the workspace has; returns the
    written paths. Nothing rendered on that path: a UserError saying what to run first."""
    validate(cfg)
    ws.require("pose")
    cams = read_cameras(ws)
    frames_dir = ws.render_dir(cfg.path)
    frames = rendered_frames(frames_dir)
    if not frames:
        raise UserError(f"nothing rendered in {frames_dir} to export: run `deflare-scene "
                        f"render {shell_path(ws.root)} --path {cfg.path}` first")
    inputs = [ws.cameras_json, frames_dir, ws.deflared, ws.masks, *ws.depth_inputs()]
    stage_run = ws.begin_stage("export", asdict(cfg), inputs, force,
                                defaults=asdict(ExportConfig()))
    if stage_run.skip:
        info("export: up to date")
        return stage_run.outputs
    outs = [write_path_video(frames, ws.video_of(cfg.path), cfg.fps, cfg.crf)]
    if cfg.compare:
        outs += write_comparisons(ws, cams, cfg)
    if cfg.glb:
        glb = write_glb(ws, cams, frames_dir)
        outs += [glb] if glb else []
    if cfg.transforms:
        outs += write_transforms(ws, cams)
    if cfg.points:
        ply = write_points(ws, cams, cfg.max_points)
        outs += [ply] if ply else []
    return stage_run.finish(outs, versions=["imageio-ffmpeg"])


# --------------------------------------------------------------------------- videos
REWRITE = "delete it and rerun the stage that wrote it"
"""What to do about an unreadable frame or photo (``pipeline.images.read_image``'s fix)."""


def write_path_video(frames: list[Path], out: Path, fps: float, crf: int) -> Path:
    """H.264 video of numbered frames (all one size)."""
    from pipeline.video import write_video

    def gen():
        size = None
        for p in track(frames, f"video {out.name}"):
            img = read_image(p, fix=REWRITE)
            if size and img.shape != size:
                raise UserError(f"{p} is {img.shape[1]}x{img.shape[0]}, other frames are "
                                f"{size[1]}x{size[0]}: rerender the path with --force")
            size = img.shape
            yield img

    write_video(out, gen(), fps=fps, crf=crf)
    info(f"wrote {out} ({len(frames)} frames at {fps:g} fps)")
    return out


def side_by_side(a: np.ndarray, b: np.ndarray, height: int | None = None) -> np.ndarray:
    """Two RGB images side by side at one height (``b`` resized to ``a``'s height)."""
    import cv2

    h = height or a.shape[0]

    def fit(x):
        if x.shape[0] == h:
            return x
        w = max(1, round(x.shape[1] * h / x.shape[0]))
        return cv2.resize(x, (w, h), interpolation=cv2.INTER_AREA)

    return np.concatenate([fit(a), fit(b)], 1)


def write_comparisons(ws: Workspace, cams: Cameras, cfg: ExportConfig) -> list[Path]:
    """WS/<scene>_compare.mp4 and .jpg: decoded | deflared for every input view."""
    import cv2

    from pipeline.video import write_video

    stems = [f.stem for f in cams.frames if ws.deflared_path(f.stem).exists()]
    if not stems:
        warn(f"no de-flared photos in {ws.deflared}: run "
             f"`deflare-scene render {shell_path(ws.root)} --path inputs` first; skipping the "
             "comparisons")
        return []
    height = read_decoded(ws, stems[0]).shape[0]
    pairs = [side_by_side(read_decoded(ws, s), read_image(ws.deflared_path(s), fix=REWRITE),
                          height)
             for s in track(stems, "comparisons")]
    pairs = centred(pairs)
    mp4, jpg = ws.compare_video, ws.compare_sheet
    # each view held for one second; frames repeated so any player shows them
    hold = max(1, round(cfg.fps))
    write_video(mp4, (p for p in pairs for _ in range(hold)), fps=cfg.fps, crf=cfg.crf)
    sheet = contact_sheet(pairs, long_side=2400)
    atomic_imwrite(jpg, sheet[..., ::-1], [cv2.IMWRITE_JPEG_QUALITY, 90])
    info(f"wrote {mp4} and {jpg} ({len(stems)} views: input | de-flared)")
    return [mp4, jpg]


def centred(tiles: list[np.ndarray]) -> list[np.ndarray]:
    """Tiles of one height padded with black to the widest, each in the middle: a portrait
    photo's pair among landscape ones sits centred in the video and the sheet."""
    width = max(t.shape[1] for t in tiles)
    out = []
    for t in tiles:
        left = (width - t.shape[1]) // 2
        out.append(np.pad(t, ((0, 0), (left, width - t.shape[1] - left), (0, 0))))
    return out


def contact_sheet(tiles: list[np.ndarray], long_side: int = 2400) -> np.ndarray:
    """Tiles (one size) stacked in rows, 2 per row, downscaled so the sheet's long side is
    at most ``long_side``."""
    import cv2

    cols = 1 if len(tiles) == 1 else 2
    rows = -(-len(tiles) // cols)
    h, w = tiles[0].shape[:2]
    sheet = np.zeros((rows * h, cols * w, 3), np.uint8)
    for i, t in enumerate(tiles):
        r, c = divmod(i, cols)
        sheet[r * h:(r + 1) * h, c * w:(c + 1) * w] = t
    s = min(1.0, long_side / max(sheet.shape[:2]))
    if s < 1.0:
        sheet = cv2.resize(sheet, (max(1, round(sheet.shape[1] * s)),
                                   max(1, round(sheet.shape[0] * s))),
                           interpolation=cv2.INTER_AREA)
    return sheet


# --------------------------------------------------------------------------- points.ply
def ply_bytes(xyz: np.ndarray, rgb: np.ndarray) -> bytes:
    """A binary little-endian PLY of coloured points (float x, y, z; uchar red, green, blue)."""
    rows = np.empty(len(xyz), dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"),
                                     ("red", "u1"), ("green", "u1"), ("blue", "u1")])
    for i, k in enumerate("xyz"):
        rows[k] = xyz[:, i]
    for i, k in enumerate(("red", "green", "blue")):
        rows[k] = rgb[:, i]
    header = ("ply\nformat binary_little_endian 1.0\ncomment deflare-scene: depth maps, "
              f"world frame of cameras.json\nelement vertex {len(rows)}\n"
              "property float x\nproperty float y\nproperty float z\n"
              "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n")
    return header.encode("ascii") + rows.tobytes()


def write_points(ws: Workspace, cams: Cameras, max_points: int) -> Path | None:
    """WS/points.ply from the depth maps (at most ``max_points``, an even sample); None,
    with a message, when the depth stage has not run or found no depth."""
    from pipeline.workspace import atomic_write_bytes

    if not ws.depth.is_dir():
        warn(f"no depth maps in {ws.depth}: run `deflare-scene depth {shell_path(ws.root)}` "
             "for WS/points.ply; skipping it")
        return None
    from pipeline.depth import depth_points

    xyz, rgb = depth_points(ws, cams)
    if not len(xyz):
        warn(f"the depth maps in {ws.depth} know no pixel: no WS/points.ply")
        return None
    if len(xyz) > max_points:
        keep = np.sort(np.random.default_rng(0).choice(len(xyz), max_points, replace=False))
        xyz, rgb = xyz[keep], rgb[keep]
    atomic_write_bytes(ws.points_ply, ply_bytes(xyz, rgb))
    info(f"wrote {ws.points_ply} ({len(xyz)} points from the depth maps)")
    return ws.points_ply


# --------------------------------------------------------------------------- scene.glb
def write_glb(ws: Workspace, cams: Cameras, frames_dir: Path) -> Path | None:
    """Rewrite WS/scene.glb: its sparse points, the input cameras and the rendered path
    (the cameras of ``frames_dir/cameras.json``, pipeline.render.path_cameras: each frame's
    frustum with its own intrinsics)."""
    from pipeline.scene_glb import read_scene_points, write_scene_glb

    path_cams = path_cameras(frames_dir)
    if path_cams is None:
        warn(f"no rendered path in {frames_dir}: scene.glb left without a path")
        return ws.scene_glb if ws.scene_glb.exists() else None
    if ws.scene_glb.exists():
        points, colors = read_scene_points(ws.scene_glb)
    else:
        points, colors = np.zeros((0, 3)), np.zeros((0, 3), np.uint8)
    write_scene_glb(ws.scene_glb, points, colors, cams.frames, extra_paths=[path_cams])
    info(f"wrote {ws.scene_glb} ({len(points)} points, {len(cams.frames)} cameras, path of "
         f"{len(path_cams)} poses)")
    return ws.scene_glb


# --------------------------------------------------------------------------- nerfstudio
def nerfstudio_camera(frame: Frame) -> tuple[str, dict] | None:
    """(camera_model, intrinsics) of WS/decoded/<stem>.png in nerfstudio's terms, or None
    when its COLMAP model has no nerfstudio equivalent (FULL_OPENCV's rational terms)."""
    if not frame.colmap_camera:
        return None
    cam = CameraModel.from_colmap(frame.colmap_camera).as_two_focal()
    (fx, fy), (cx, cy) = cam.focal, cam.principal
    d = {"fl_x": fx, "fl_y": fy, "cx": cx, "cy": cy, "w": cam.width, "h": cam.height}
    if cam.model == "PINHOLE":
        return "OPENCV", {**d, "k1": 0.0, "k2": 0.0, "p1": 0.0, "p2": 0.0}
    if cam.model == "OPENCV":
        k1, k2, p1, p2 = (float(v) for v in cam.dist)
        return "OPENCV", {**d, "k1": k1, "k2": k2, "p1": p1, "p2": p2}
    if cam.model == "OPENCV_FISHEYE":
        return "OPENCV_FISHEYE", {**d, **{f"k{i + 1}": float(v) for i, v in
                                          enumerate(cam.dist)}}
    return None


def nerfstudio_transforms(ws: Workspace, cams: Cameras, with_masks: bool) -> dict:
    """nerfstudio ``transforms.json`` of the workspace.

    Choice: the ORIGINAL framing, ``file_path: decoded/<stem>.png`` with camera_model
    OPENCV (or OPENCV_FISHEYE) and the distortion of ``colmap_camera``, per-frame
    intrinsics; when some view's model has no nerfstudio equivalent (FULL_OPENCV), every
    view falls back to PINHOLE with the undistorted ``images/<stem>.png`` and its K.
    ``transform_matrix``: camera-to-world in OpenGL axes (OpenCV c2w with y and z flipped)
    in the workspace's normalised frame; ``applied_transform``: that frame from COLMAP's
    (cameras.json colmap_to_world, 3x4). ``mask_path``: masks_nerfstudio/<stem>.png,
    0 = flare (ignored by nerfstudio), 255 = use, same size as the image.
    """
    mapped = [nerfstudio_camera(f) for f in cams.frames]
    models = {m[0] for m in mapped if m}
    original = all(mapped) and len(models) == 1
    out = {"camera_model": models.pop() if original else "PINHOLE",
           "applied_transform": np.asarray(cams.colmap_to_world)[:3].tolist(), "frames": []}

    def rel(path: Path) -> str:
        return path.relative_to(ws.root).as_posix()

    for f, m in zip(cams.frames, mapped, strict=True):
        if original:
            entry = {"file_path": rel(ws.decoded_path(f.stem)), **m[1]}
        else:
            entry = {"file_path": rel(ws.image_path(f.stem)), "fl_x": f.K[0, 0],
                     "fl_y": f.K[1, 1], "cx": f.K[0, 2], "cy": f.K[1, 2],
                     "w": f.width, "h": f.height}
        entry["transform_matrix"] = (np.asarray(f.c2w) @ CV_GL).tolist()
        if with_masks:
            entry["mask_path"] = rel(ws.masks_nerfstudio_path(f.stem))
        out["frames"].append({k: (float(v) if isinstance(v, np.floating) else v)
                              for k, v in entry.items()})
    return out


def write_transforms(ws: Workspace, cams: Cameras) -> list[Path]:
    """WS/transforms.json and, when masks exist, WS/masks_nerfstudio/<stem>.png."""
    with_masks = has_masks(ws, cams.stems)
    data = nerfstudio_transforms(ws, cams, with_masks)
    outs = []
    if with_masks:
        first = cams.frames[0]  # the original framing: decoded/ images, not images/
        original = ws.root / data["frames"][0]["file_path"] == ws.decoded_path(first.stem)
        for f in track(cams.frames, "nerfstudio masks"):
            if original:
                h, w = image_size(ws.decoded_path(f.stem), fix=ws.rerun("decode"))
                flare = flare_mask_in(decoded_camera(f, w, h), f, ws)
            else:
                flare = read_mask(ws, f.stem)
            atomic_imwrite(ws.masks_nerfstudio_path(f.stem),
                           np.where(flare, 0, 255).astype(np.uint8))
        outs.append(ws.masks_nerfstudio)
    else:
        warn(f"no flare masks in {ws.masks}: transforms.json written without mask_path")
    atomic_write_json(ws.transforms_json, data)
    info(f"wrote {ws.transforms_json} ({data['camera_model']}, {len(cams.frames)} frames)")
    return [ws.transforms_json, *outs]
