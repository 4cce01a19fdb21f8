"""Scenes as training tensors (``gnfr.train.Scene``) from a workspace, LLFF or COLMAP folder.

Three layouts:

* a deflare-scene workspace (``WS/images``, ``WS/cameras.json``, optional ``WS/masks`` and
  ``WS/views.json``, all read through ``pipeline.ws_files``);
* an LLFF folder (``poses_bounds.npy`` + ``images/`` or ``images_<f>/``);
* a COLMAP workspace (``sparse/`` or ``sparse/0`` + ``images/``), read by the small
  pure-python binary/text reader below (no pycolmap);
* a scene pack (``DIR/scene_pack.npz``, written by ``save_pack``): any of the above as loaded,
  its views as JPEG bytes beside their cameras, one small file to move training data to
  another machine (a GPU's: ``python -m workflows.research.scene_pack``).

LLFF and COLMAP scenes are brought into the workspace's normalised frame: camera centres
centred at the origin within a sphere of radius about 1 (near/far scaled alike;
``pipeline.cameras.normalising_scale``).
"""

from __future__ import annotations

import re
import struct
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import torch

from gnfr.train import Scene
from pipeline.cameras import normalising_scale
from pipeline.errors import UserError, shell_path
from pipeline.images import image_size, is_photo, list_photos, read_image
from pipeline.progress import warn
from pipeline.workspace import Workspace
from pipeline.ws_files import enclosed_holes, grow_mask, read_cameras, read_mask, read_views

PACK_FILE = "scene_pack.npz"
"""A scene pack's file name (``save_pack``)."""


# --------------------------------------------------------------------------- helpers
def rank_by_distance(stems: Sequence[str], centers: np.ndarray) -> dict[str, list[str]]:
    """Per stem, every other stem by camera-centre distance, nearest first (stable)."""
    d = np.linalg.norm(centers[:, None] - centers[None], axis=-1)
    out = {}
    for i, s in enumerate(stems):
        order = [j for j in np.argsort(d[i], kind="stable") if j != i]
        out[s] = [stems[j] for j in order]
    return out


def make_scene(name: str, stems: list[str], images: list[np.ndarray], K: np.ndarray,
               c2w: np.ndarray, near: np.ndarray, far: np.ndarray,
               masks: list[np.ndarray] | None = None, flare: dict | None = None,
               ranked: dict | None = None, targets: list[str] | None = None) -> Scene:
    """Stack per-view arrays (images [H, W, 3] uint8, masks [H, W] bool, each view at its
    own size) into a Scene; ``targets`` None: the training targets follow
    ``TrainConfig.max_flare``. Views of different sizes (a portrait photo among landscape
    ones) are padded at the bottom and right to the largest height and width, as the
    render's source cache pads them (``pipeline.render.sources.encode_sources``): black, its
    mask flare, and ``Scene.extents`` keeps each view's own size. Nothing is resized: a
    view's intrinsics stay its own. A view's flare fraction is of its own pixels."""
    if flare is None:
        flare = {s: float(mk.mean()) if masks is not None else 0.0
                 for s, mk in zip(stems, masks or [None] * len(stems), strict=True)}
    sizes = [im.shape[:2] for im in images]
    extents = None
    if len(set(sizes)) > 1:
        H, W = max(h for h, _ in sizes), max(w for _, w in sizes)
        extents = torch.tensor([[w, h] for h, w in sizes], dtype=torch.long)
        images = [_pad(im, H, W, 0) for im in images]
        if masks is not None:
            masks = [_pad(np.asarray(mk, bool), H, W, True) for mk in masks]
    imgs = torch.from_numpy(np.stack(images)).permute(0, 3, 1, 2).contiguous()
    m = None
    if masks is not None:
        m = torch.from_numpy(np.stack(masks).astype(np.uint8))[:, None]
    if ranked is None:
        ranked = rank_by_distance(stems, c2w[:, :3, 3])
    return Scene(stems=stems, images=imgs, K=torch.as_tensor(K, dtype=torch.float64),
                 c2w=torch.as_tensor(c2w, dtype=torch.float64),
                 near=torch.as_tensor(near, dtype=torch.float64),
                 far=torch.as_tensor(far, dtype=torch.float64), masks=m, flare=flare,
                 ranked=ranked, name=name, targets=targets, extents=extents)


def _pad(a: np.ndarray, H: int, W: int, value) -> np.ndarray:
    """``a`` ([h, w] or [h, w, C]) padded at the bottom and right to [H, W(, C)] with
    ``value``."""
    out = np.full((H, W) + a.shape[2:], value, dtype=a.dtype)
    out[:a.shape[0], :a.shape[1]] = a
    return out


def scene_views(scene: Scene) -> tuple[list[np.ndarray], list[np.ndarray] | None]:
    """The views of ``scene`` as arrays at their own sizes (padding cut off,
    ``Scene.extents``): images [h, w, 3] uint8 and masks [h, w] bool (None without masks);
    ``make_scene`` takes them back."""
    images, masks = [], None if scene.masks is None else []
    for i in range(len(scene.stems)):
        images.append(np.ascontiguousarray(scene.own(i, scene.images[i]).permute(1, 2, 0)
                                           .numpy()))
        if masks is not None:
            masks.append(scene.own(i, scene.masks[i, 0]).numpy().astype(bool))
    return images, masks


def normalise(c2w: np.ndarray, near: np.ndarray, far: np.ndarray):
    """Centre camera centres at the origin and scale them into the unit sphere (the
    workspace convention); returns scaled copies of c2w [N, 4, 4], near [N], far [N]."""
    c2w = c2w.copy()
    centre = c2w[:, :3, 3].mean(0)
    # forward-facing captures: keep the scene depth reasonable when cameras barely move
    s = normalising_scale(c2w[:, :3, 3], centre, min_radius=0.1 * float(np.median(near)))
    c2w[:, :3, 3] = (c2w[:, :3, 3] - centre) * s
    return c2w, near * s, far * s


# --------------------------------------------------------------------------- workspace
def load_workspace(root: str | Path, stems: Sequence[str] | None = None,
                   holes_as_flare: bool = False, gains: dict | None = None,
                   grow: float = 0.0, pad: bool = False) -> Scene:
    """A workspace's posed views (and masks / views.json when present) as a Scene. With
    views.json its flags are the training targets (``ViewsFile.targets``, the rule select
    applied with its --max-flare); without it the training config's max_flare decides.
    ``holes_as_flare``: each mask with what it encloses marked too
    (``pipeline.ws_files.enclosed_holes``; the views' flare fractions stay select's). Off
    here, so a workspace read as a pretraining scene keeps its masks as they are; the
    fine-tune passes its own ``FinetuneConfig.holes_as_flare`` (on by default). ``gains``:
    {stem: [3] linear gain} applied to the views (``pipeline.exposure``). ``grow``: each
    mask grown by this fraction of the long side (a disc; ``grow_mask``), after the holes;
    the flare fractions stay select's. Views of another size than the most common one (a
    portrait photo among landscape ones): stretched to it, intrinsics scaled alike; with
    ``pad`` kept at their own size and padded (``make_scene``, ``Scene.extents``), as the
    render pads its sources (``FinetuneConfig.pad_views``)."""
    ws = Workspace(root)
    cams = read_cameras(ws)
    frames = [f for f in cams.frames if stems is None or f.stem in stems]
    names = [f.stem for f in frames]
    sizes = [(f.width, f.height) for f in frames]
    common = max(sizes, key=sizes.count)  # the most common size (the first of a tie)
    size = {f.stem: (f.width, f.height) if pad else common for f in frames}
    images, Ks = [], []
    for f in frames:
        img = read_image(ws.image_path(f.stem), size=size[f.stem], fix=ws.rerun("pose"))
        if gains and f.stem in gains:
            from pipeline.exposure import apply_gain

            img = apply_gain(img, gains[f.stem])
        images.append(img)
        K = np.array(f.K, float)
        K[0] *= size[f.stem][0] / f.width
        K[1] *= size[f.stem][1] / f.height
        Ks.append(K)
    masks = None
    if ws.masks.is_dir():
        masks = [read_mask(ws, f.stem, size[f.stem]) for f in frames]
        if holes_as_flare:
            masks = [m | enclosed_holes(m) for m in masks]
    else:
        warn(f"{ws.masks} is missing: treating every view as flare-free (run `deflare-scene "
             f"mask {shell_path(ws.root)}` for GN-FR's flare handling)")
    flare = ranked = targets = None
    if masks is not None and grow > 0:  # the fractions (the 10 % rule's) before the growth
        flare = {s: float(m.mean()) for s, m in zip(names, masks, strict=True)}
        masks = [grow_mask(m, grow) for m in masks]
    if ws.views_json.exists():
        views = read_views(ws)
        flare, ranked = views.fractions(names), views.ranked(names)
        targets = views.targets()
    return make_scene(Path(root).name, names, images, np.stack(Ks),
                      np.stack([f.c2w for f in frames]), np.array([f.near for f in frames]),
                      np.array([f.far for f in frames]), masks, flare, ranked, targets)


# --------------------------------------------------------------------------- LLFF
def llff_to_opencv(poses: np.ndarray) -> np.ndarray:
    """LLFF [N, 3, 5] poses (columns down, right, back, centre, hwf) -> OpenCV c2w
    [N, 4, 4] (x right, y down, z forward)."""
    c2w = np.tile(np.eye(4), (len(poses), 1, 1))
    c2w[:, :3, 0] = poses[:, :, 1]
    c2w[:, :3, 1] = poses[:, :, 0]
    c2w[:, :3, 2] = -poses[:, :, 2]
    c2w[:, :3, 3] = poses[:, :, 3]
    return c2w


def read_poses_bounds(path: Path) -> np.ndarray:
    """LLFF's ``poses_bounds.npy`` as an [N, 17] float array; a file that is not one (not a
    NumPy array, pickled objects, another shape, non-finite values) is a UserError naming it."""
    what = "an LLFF poses_bounds.npy (N rows of 17 numbers: 3x5 pose, near, far)"
    try:
        pb = np.load(path, allow_pickle=False)
    except (OSError, ValueError, EOFError) as e:
        raise UserError(f"{path} cannot be read as {what} ({e.__class__.__name__}): "
                        "regenerate it with LLFF's imgs2poses or remove it") from None
    if pb.ndim != 2 or pb.shape[0] == 0 or pb.shape[1] != 17 or not np.isfinite(pb).all():
        raise UserError(f"{path} holds a {pb.dtype} array of shape {pb.shape}, not {what} "
                        "with finite values: regenerate it with LLFF's imgs2poses")
    return pb.astype(np.float64)


def load_llff(folder: str | Path, max_size: int = 504) -> Scene:
    """An LLFF scene (``poses_bounds.npy``: N rows of a 3x5 [R|t|hwf] + near, far)."""
    folder = Path(folder)
    pb = read_poses_bounds(folder / "poses_bounds.npy")
    poses, bounds = pb[:, :15].reshape(-1, 3, 5), pb[:, 15:17]
    img_dir = _llff_image_dir(folder, max_size)
    files = list_photos(img_dir)
    if len(files) != len(poses):
        raise UserError(f"{img_dir} has {len(files)} images but poses_bounds.npy "
                        f"{len(poses)} poses")
    H0, W0, f0 = poses[0, :, 4]
    h, w = image_size(files[0])
    if abs((w / W0) / (h / H0) - 1) > 0.01:
        raise UserError(f"{files[0]} is {w}x{h} but poses_bounds.npy says {W0:.0f}x{H0:.0f} "
                        "(another aspect: rotated or cropped images?); use the images the "
                        "poses were made for")
    s = min(1.0, max_size / max(h, w))
    W, H = round(w * s), round(h * s)
    K = np.array([[f0 * W / W0, 0, W / 2], [0, f0 * H / H0, H / 2], [0, 0, 1]])
    c2w, near, far = normalise(llff_to_opencv(poses), bounds[:, 0] * 0.9, bounds[:, 1] * 1.1)
    images = [read_image(p, size=(W, H)) for p in files]
    return make_scene(folder.name, [p.stem for p in files], images, np.tile(K, (len(files), 1, 1)),
                      c2w, near, far)


def _llff_image_dir(folder: Path, max_size: int) -> Path:
    """``images/`` or the ``images_<factor>/`` whose images are the smallest still at least
    ``max_size`` on their long side (else the largest)."""
    cands = sorted((p for p in folder.iterdir()
                    if p.is_dir() and re.fullmatch(r"images(_\d+)?", p.name)),
                   key=lambda p: int(p.name.split("_")[1]) if "_" in p.name else 1)
    if not cands:
        raise UserError(f"{folder} has poses_bounds.npy but no images/ or images_<factor>/ "
                        "folder")
    for p in reversed(cands):  # the smallest images still at least max_size
        first = next((x for x in sorted(p.iterdir()) if is_photo(x)), None)
        try:
            big = first is not None and max(image_size(first)) >= max_size
        except UserError:  # an unreadable image: this folder cannot serve
            big = False
        if big:
            return p
    return cands[0]


# --------------------------------------------------------------------------- COLMAP
# model id -> (name, number of params); K from params: f, cx, cy or fx, fy, cx, cy
COLMAP_MODELS = {0: ("SIMPLE_PINHOLE", 3), 1: ("PINHOLE", 4), 2: ("SIMPLE_RADIAL", 4),
                 3: ("RADIAL", 5), 4: ("OPENCV", 8), 5: ("OPENCV_FISHEYE", 8),
                 6: ("FULL_OPENCV", 12), 7: ("FOV", 5), 8: ("SIMPLE_RADIAL_FISHEYE", 4),
                 9: ("RADIAL_FISHEYE", 5), 10: ("THIN_PRISM_FISHEYE", 12)}
SINGLE_FOCAL = {"SIMPLE_PINHOLE", "SIMPLE_RADIAL", "RADIAL", "SIMPLE_RADIAL_FISHEYE",
                "RADIAL_FISHEYE"}


def _unpack(f, fmt: str):
    return struct.unpack("<" + fmt, f.read(struct.calcsize("<" + fmt)))


def read_colmap_bin(folder: Path) -> tuple[dict, dict, dict]:
    """cameras {id: (model, w, h, params)}, images {id: (qvec, tvec, cam_id, name,
    point3D_ids)}, points {id: xyz} from a binary COLMAP model."""
    cams, imgs, pts = {}, {}, {}
    with open(folder / "cameras.bin", "rb") as f:
        for _ in range(_unpack(f, "Q")[0]):
            cid, mid, w, h = _unpack(f, "iiQQ")
            name, n = COLMAP_MODELS[mid]
            cams[cid] = (name, w, h, np.array(_unpack(f, f"{n}d")))
    with open(folder / "images.bin", "rb") as f:
        for _ in range(_unpack(f, "Q")[0]):
            iid, *qt, cid = _unpack(f, "i7di")
            name = b""
            while (c := f.read(1)) != b"\0":
                name += c
            n2d = _unpack(f, "Q")[0]
            data = np.frombuffer(f.read(24 * n2d), dtype=[("x", "<f8"), ("y", "<f8"),
                                                          ("id", "<i8")])
            imgs[iid] = (np.array(qt[:4]), np.array(qt[4:]), cid, name.decode(), data["id"])
    with open(folder / "points3D.bin", "rb") as f:
        for _ in range(_unpack(f, "Q")[0]):
            pid, x, y, z, _r, _g, _b, _err, tl = _unpack(f, "Q3d3BdQ")
            f.seek(8 * tl, 1)
            pts[pid] = (x, y, z)
    return cams, imgs, pts


def read_colmap_text(folder: Path) -> tuple[dict, dict, dict]:
    """The same as :func:`read_colmap_bin` from cameras.txt / images.txt / points3D.txt."""
    def lines(name):
        return [ln for ln in (folder / name).read_text().splitlines()
                if ln.strip() and not ln.startswith("#")]
    cams, imgs, pts = {}, {}, {}
    for ln in lines("cameras.txt"):
        p = ln.split()
        cams[int(p[0])] = (p[1], int(p[2]), int(p[3]), np.array(p[4:], float))
    il = (folder / "images.txt").read_text().splitlines()
    il = [ln for ln in il if not ln.startswith("#")]
    for head, pts2d in zip(il[0::2], il[1::2], strict=False):
        p = head.split()
        if not p:
            continue
        ids = np.array(pts2d.split()[2::3], dtype=np.int64)
        imgs[int(p[0])] = (np.array(p[1:5], float), np.array(p[5:8], float), int(p[8]),
                           " ".join(p[9:]), ids)
    for ln in lines("points3D.txt"):
        p = ln.split()
        pts[int(p[0])] = tuple(float(v) for v in p[1:4])
    return cams, imgs, pts


def qvec_to_rotmat(q: np.ndarray) -> np.ndarray:
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def colmap_K(model: str, params: np.ndarray) -> np.ndarray:
    if model in SINGLE_FOCAL:
        f, cx, cy = params[:3]
        return np.array([[f, 0, cx], [0, f, cy], [0, 0, 1.0]])
    fx, fy, cx, cy = params[:4]
    return np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1.0]])


def _colmap_model_dir(folder: Path) -> Path | None:
    for cand in (folder / "sparse" / "0", folder / "sparse", folder):
        if (cand / "cameras.bin").is_file() or (cand / "cameras.txt").is_file():
            return cand
    return None


def colmap_model_dir(folder: Path) -> Path:
    found = _colmap_model_dir(folder)
    if found is not None:
        return found
    raise UserError(f"{folder} has no COLMAP model (cameras.bin/.txt in sparse/0, sparse/ "
                    "or the folder itself)")


def load_colmap(folder: str | Path, max_size: int = 504) -> Scene:
    """A COLMAP workspace (sparse model + ``images/``) as a Scene; near/far per view from
    the depths of the 3D points it sees (1st / 99th percentile, with margins). Views of
    different sizes are padded (``make_scene``)."""
    folder = Path(folder)
    model = colmap_model_dir(folder)
    binary = (model / "cameras.bin").is_file()
    cams, imgs, pts = read_colmap_bin(model) if binary else read_colmap_text(model)
    xyz_ids = np.array(sorted(pts), dtype=np.int64)
    xyz = np.array([pts[i] for i in xyz_ids]).reshape(-1, 3)
    stems, images, Ks, c2ws, nears, fars = [], [], [], [], [], []
    for _iid, (q, t, cid, name, pids) in sorted(imgs.items(), key=lambda kv: kv[1][3]):
        mname, w, h, params = cams[cid]
        if mname not in ("PINHOLE", "SIMPLE_PINHOLE"):
            warn(f"{model}: camera {cid} is {mname}; distortion is ignored (undistort with "
                 "COLMAP's image_undistorter for exact results)")
        s = min(1.0, max_size / max(w, h))
        W, H = round(w * s), round(h * s)
        K = colmap_K(mname, params)
        K[0] *= W / w
        K[1] *= H / h
        R = qvec_to_rotmat(q)
        c2w = np.eye(4)
        c2w[:3, :3], c2w[:3, 3] = R.T, -R.T @ t
        seen = xyz[np.isin(xyz_ids, pids[pids >= 0])]
        z = (seen @ R.T + t)[:, 2] if len(seen) else np.zeros(0)
        z = z[z > 0]
        near, far = (np.percentile(z, 1) * 0.8, np.percentile(z, 99) * 1.2) if len(z) > 4 \
            else (0.1, 100.0)
        stems.append(Path(name).stem)
        images.append(read_image(folder / "images" / name, size=(W, H)))
        Ks.append(K)
        c2ws.append(c2w)
        nears.append(near)
        fars.append(far)
    c2w, near, far = normalise(np.stack(c2ws), np.array(nears), np.array(fars))
    return make_scene(folder.name, stems, images, np.stack(Ks), c2w, near, far)


def scene_layout(path: str | Path) -> str | None:
    """Which of the layouts above the folder ``path`` holds: ``pack``, ``workspace``,
    ``llff`` or ``colmap`` (``images/`` and a model in ``sparse/0``, ``sparse/`` or the
    folder itself); None when it holds no scene. The one test that both
    ``detect_and_load`` and ``pretrain``'s scene search use."""
    path = Path(path)
    if (path / PACK_FILE).is_file():
        return "pack"
    if Workspace(path).cameras_json.is_file():
        return "workspace"
    if (path / "poses_bounds.npy").is_file():
        return "llff"
    if (path / "images").is_dir() and _colmap_model_dir(path) is not None:
        return "colmap"
    return None


def detect_and_load(path: str | Path, max_size: int = 504) -> Scene:
    """Load a workspace, an LLFF folder, a COLMAP workspace or a scene pack, whichever
    ``path`` is (``scene_layout``)."""
    path = Path(path)
    layout = scene_layout(path)
    if layout == "pack":
        return load_pack(path, max_size)
    if layout == "workspace":
        return load_workspace(path)
    if layout == "llff":
        return load_llff(path, max_size)
    if layout == "colmap":
        return load_colmap(path, max_size)
    raise UserError(f"{path} is not a workspace (cameras.json), an LLFF scene "
                    "(poses_bounds.npy), a COLMAP workspace (images/ + a model in sparse/) "
                    f"or a scene pack ({PACK_FILE})")


# --------------------------------------------------------------------------- scene packs
def save_pack(scene: Scene, folder: str | Path, quality: int = 95) -> Path:
    """``scene`` as ``folder/scene_pack.npz``: views as JPEG (``quality``), intrinsics,
    OpenCV c2w, near/far, masks bit-packed when the scene has them, targets; views of
    different sizes each at its own size (``Scene.extents``), their masks padded to the
    largest (``load_pack`` cuts each to its view's JPEG size). What it drops: the exact
    pixels (JPEG), and ``ranked``/``flare`` (recomputed from cameras and masks)."""
    import cv2

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    blobs = []
    for img in scene_views(scene)[0]:
        ok, buf = cv2.imencode(".jpg", np.ascontiguousarray(img[..., ::-1]),
                               [cv2.IMWRITE_JPEG_QUALITY, quality])
        if not ok:
            raise UserError(f"{scene.name}: a view could not be encoded as JPEG")
        blobs.append(buf.ravel())
    extra = {}
    if scene.masks is not None:
        extra["masks"] = np.packbits(scene.masks.numpy().astype(bool), axis=-1)
    if scene.targets is not None:
        extra["targets"] = np.array(scene.targets)
    out = folder / PACK_FILE
    tmp = out.with_suffix(".tmp.npz")
    np.savez(tmp, name=np.array(scene.name), stems=np.array(scene.stems),
             jpeg=np.concatenate(blobs), offsets=np.cumsum([0] + [len(b) for b in blobs]),
             K=scene.K.numpy(), c2w=scene.c2w.numpy(), near=scene.near.numpy(),
             far=scene.far.numpy(), **extra)
    tmp.replace(out)
    return out


def load_pack(folder: str | Path, max_size: int = 504) -> Scene:
    """A scene pack as a Scene, shrunk (intrinsics alike) when its long side exceeds
    ``max_size``; never enlarged."""
    import cv2

    path = Path(folder) / PACK_FILE
    try:
        with np.load(path, allow_pickle=False) as npz:
            d = {k: npz[k] for k in npz.files}
        off, blob = d["offsets"], d["jpeg"]
        images = [cv2.imdecode(blob[a:b], cv2.IMREAD_COLOR)[..., ::-1]
                  for a, b in zip(off[:-1], off[1:], strict=True)]
        missing = {"name", "stems", "K", "c2w", "near", "far"} - set(d)
        if missing or not images or any(im is None for im in images):
            raise ValueError(f"missing {sorted(missing)}" if missing else "bad JPEG data")
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise UserError(f"{path}: not a readable scene pack ({e}); write it again with "
                        "`python -m workflows.research.scene_pack`") from e
    masks = None
    if "masks" in d:  # stored padded to the largest view: each cut to its own view's size
        w = max(im.shape[1] for im in images)
        masks = [m[:im.shape[0], :im.shape[1]] for m, im in zip(
            np.unpackbits(d["masks"], axis=-1, count=w)[:, 0].astype(bool), images,
            strict=True)]
    images, masks, K = _shrink(images, masks, d["K"], max_size)
    targets = [str(t) for t in d["targets"]] if "targets" in d else None
    return make_scene(str(d["name"]), [str(t) for t in d["stems"]], images, K, d["c2w"],
                      d["near"], d["far"], masks, targets=targets)


def shrink_scene(scene: Scene, max_size: int) -> Scene:
    """``scene`` with views (masks, intrinsics alike) shrunk to ``max_size`` on the long
    side when larger; never enlarged."""
    images, masks = scene_views(scene)
    images, masks, K = _shrink(images, masks, scene.K.numpy(), max_size)
    return make_scene(scene.name, scene.stems, images, K, scene.c2w.numpy(),
                      scene.near.numpy(), scene.far.numpy(), masks, targets=scene.targets)


def _shrink(images: list[np.ndarray], masks: list[np.ndarray] | None, K: np.ndarray,
            max_size: int):
    """(images, masks, K [N, 3, 3]) shrunk by one factor, so that the longest side of any
    view is at most ``max_size`` (views of different sizes keep their own shapes)."""
    import cv2

    K = np.array(K, dtype=np.float64, copy=True)
    s = min(1.0, max_size / max(max(im.shape[:2]) for im in images))
    if s < 1.0:
        out_i, out_m = [], None if masks is None else []
        for v, im in enumerate(images):
            h, w = im.shape[:2]
            W, H = round(w * s), round(h * s)
            out_i.append(cv2.resize(im, (W, H), interpolation=cv2.INTER_AREA))
            if masks is not None:
                out_m.append(cv2.resize(masks[v].astype(np.uint8), (W, H),
                                        interpolation=cv2.INTER_NEAREST).astype(bool))
            K[v, 0] *= W / w
            K[v, 1] *= H / h
        images, masks = out_i, out_m
    return [np.ascontiguousarray(im) for im in images], masks, K
