"""Frame files: writing frames (JPEG EXIF kept), rendered path folders and their cameras."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

from pipeline.errors import UserError
from pipeline.images import JPEG_EXTS, is_photo
from pipeline.render.jobs import FrameJob
from pipeline.workspace import (
    PATH_CAMERAS_FILE,
    atomic_imwrite,
    atomic_write_bytes,
    atomic_write_json,
    read_json,
)


# --------------------------------------------------------------------------- pixels
def to_u8(x: np.ndarray) -> np.ndarray:
    """Float RGB in 0..1 -> uint8 (rounded, clipped)."""
    return np.clip(np.rint(x * 255.0), 0, 255).astype(np.uint8)


def write_frame(path: Path, rgb: np.ndarray, exif_from: Path | None = None) -> None:
    """Write one RGB frame atomically: uint8 (PNG, JPEG with the EXIF of ``exif_from``) or
    uint16 (TIFF). The engine calls it by its name in pipeline.render.engine, where tests
    patch it to interrupt a render."""
    import cv2

    bgr = np.ascontiguousarray(rgb[..., ::-1])
    if path.suffix.lower() in JPEG_EXTS:
        ok, buf = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, 95])
        if not ok:
            raise OSError(f"could not encode {path}")
        atomic_write_bytes(path, with_exif(buf.tobytes(), exif_from))
    else:
        atomic_imwrite(path, bgr)


# --------------------------------------------------------------------------- EXIF
def _exif_segment(jpeg: bytes) -> bytes | None:
    """The APP1 Exif segment (marker included) of a JPEG file, or None."""
    i = 2
    while i + 4 <= len(jpeg) and jpeg[i] == 0xFF:
        marker, length = jpeg[i + 1], struct.unpack(">H", jpeg[i + 2:i + 4])[0]
        if marker == 0xE1 and jpeg[i + 4:i + 10] == b"Exif\x00\x00":
            return jpeg[i:i + 2 + length]
        if marker == 0xDA:  # start of scan: no more metadata
            return None
        i += 2 + length
    return None


def _reset_orientation(seg: bytes) -> bytes:
    """The Exif segment with IFD0's Orientation tag (0x0112) set to 1 (upright)."""
    b = bytearray(seg)
    tiff = 10  # marker (2) + length (2) + "Exif\0\0" (6)
    end = "<" if b[tiff:tiff + 2] == b"II" else ">"
    try:
        ifd = tiff + struct.unpack(end + "I", b[tiff + 4:tiff + 8])[0]
        n = struct.unpack(end + "H", b[ifd:ifd + 2])[0]
        for k in range(n):
            e = ifd + 2 + 12 * k
            if struct.unpack(end + "H", b[e:e + 2])[0] == 0x0112:
                b[e + 8:e + 10] = struct.pack(end + "H", 1)
    except struct.error:  # truncated IFD: keep the segment as it is
        pass
    return bytes(b)


def with_exif(jpeg: bytes, source: Path | None) -> bytes:
    """``jpeg`` with the Exif segment of the JPEG file ``source`` (orientation reset)."""
    if source is None:
        return jpeg
    seg = _exif_segment(Path(source).read_bytes())
    if seg is None:
        return jpeg
    return jpeg[:2] + _reset_orientation(seg) + jpeg[2:]


# --------------------------------------------------------------------------- folders
def clear_frames(out_dir: Path) -> None:
    """Remove the image files (``pipeline.images.PHOTO_EXTS``) of an earlier, different
    render of this path (not resumable)."""
    if out_dir.is_dir():
        for p in out_dir.iterdir():
            if p.is_file() and is_photo(p):
                p.unlink()


def photos_path(frames: list) -> dict:
    """The JSON camera path (docs/camera_paths.md) with a frame at each of ``frames``' cameras
    (``pipeline.cameras.Frame``: its own intrinsics and size), each named by its stem."""
    from gnfr.paths import PathCamera, path_to_json

    return path_to_json([PathCamera(f.stem, f.K, f.c2w, f.width, f.height) for f in frames])


def write_path_cameras(out_dir: Path, jobs: list[FrameJob]) -> None:
    """``out_dir/cameras.json`` (``PATH_CAMERAS_FILE``): the novel jobs' cameras in the JSON
    path format (docs/camera_paths.md), each frame with its sources and near / far (and the
    other frames' sources cross-faded into it, ``fades``, with their weights; its gain to the
    model's common exposure, ``exposure``, where the exposure glides along the path)."""
    from gnfr.paths import PathCamera, path_to_json

    cams = [PathCamera(j.out.stem, j.camera.K, j.camera.c2w, j.camera.width, j.camera.height)
            for j in jobs]
    data = path_to_json(cams)
    for f, j in zip(data["frames"], jobs, strict=True):
        f["sources"], f["near"], f["far"] = j.sources, j.near, j.far
        if j.fades:
            f["fades"] = [{"sources": list(x.sources), "weight": round(x.weight, 6)}
                          for x in j.fades]
        if j.exposure is not None:
            f["exposure"] = list(j.exposure)
    atomic_write_json(out_dir / PATH_CAMERAS_FILE, data)


def rendered_frames(out_dir: Path) -> list[Path]:
    """The PNG frames of a rendered path folder in order (none when it does not exist)."""
    return sorted(out_dir.glob("*.png")) if out_dir.is_dir() else []


def path_cameras(out_dir: Path) -> list | None:
    """The cameras (``gnfr.paths.PathCamera``: pose, intrinsics, size) of a rendered path,
    read from its cameras.json, or None where it has none."""
    from gnfr.paths import path_from_json

    f = out_dir / PATH_CAMERAS_FILE
    if not f.is_file():
        return None
    try:
        return path_from_json(read_json(f))
    except ValueError as e:
        raise UserError(f"{f}: {e}; render the path again (--force)") from None
