"""Photo file extensions and the one image reader (OpenCV; one-line errors naming the file).

``PHOTO_EXTS`` are the ordinary image files the product reads (decode's input besides camera
raw, hand-made masks, LLFF and COLMAP image folders, FMG backgrounds), ``JPEG_EXTS`` those of
them that are JPEG; camera raw extensions are ``pipeline.decode.RAW_EXTS``. ``read_image``
returns uint8 RGB (BGR on request, for OpenCV drawing and writing; uint16 kept with
``any_depth``) and ``read_image_float`` float32 RGB in [0, 1]; a missing or unreadable file
is a ``UserError`` naming it and what to do. Decoding user photos (16-bit,
truncated JPEGs, raw) is ``pipeline.decode``'s job, not this module's.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from pipeline.errors import UserError

PHOTO_EXTS: tuple[str, ...] = (".png", ".jpg", ".jpeg", ".jpe", ".tif", ".tiff", ".bmp",
                               ".webp")
"""Ordinary image extensions (lower case), read with OpenCV; ``.png`` first, so a folder
with two files of one stem prefers the lossless one."""
JPEG_EXTS: tuple[str, ...] = (".jpg", ".jpeg", ".jpe")
"""The JPEG ones of ``PHOTO_EXTS`` (Exif carried over, truncation checked)."""


def is_photo(path: str | os.PathLike) -> bool:
    """True when ``path`` has one of ``PHOTO_EXTS`` (any case)."""
    return Path(path).suffix.lower() in PHOTO_EXTS


def list_photos(folder: str | os.PathLike, recursive: bool = False) -> list[Path]:
    """Sorted image files (``PHOTO_EXTS``, hidden files left out) of ``folder``."""
    folder = Path(folder)
    found = folder.rglob("*") if recursive else folder.iterdir()
    return sorted(p for p in found
                  if p.is_file() and is_photo(p) and not p.name.startswith("."))


def _unreadable(path: Path, fix: str | None) -> UserError:
    what = "is missing" if not path.exists() else "is not a readable image"
    return UserError(f"{path} {what}: {fix or 'replace or remove it'}")


def _imread(path: str | os.PathLike, flags: int, fix: str | None) -> np.ndarray:
    """``cv2.imread`` of a file that exists (a missing one is not handed to OpenCV, which
    would print its own warning), else the one-line ``UserError`` of ``_unreadable``."""
    import cv2

    path = Path(path)
    img = cv2.imread(str(path), flags) if path.is_file() else None
    if img is None:
        raise _unreadable(path, fix)
    return img


def read_image(path: str | os.PathLike, *, bgr: bool = False,
               size: tuple[int, int] | None = None, fix: str | None = None,
               any_depth: bool = False) -> np.ndarray:
    """[H, W, 3] uint8 RGB (or BGR with ``bgr``) of an image file, EXIF orientation applied,
    area-resized to ``size`` (width, height) when given and different; with ``any_depth`` a
    16-bit file stays uint16. A missing or unreadable file is a one-line ``UserError``
    naming it; ``fix`` says what to do (default: replace or remove it)."""
    import cv2

    flags = cv2.IMREAD_COLOR | (cv2.IMREAD_ANYDEPTH if any_depth else 0)
    img = _imread(path, flags, fix)
    if size is not None and (img.shape[1], img.shape[0]) != tuple(size):
        img = cv2.resize(img, tuple(size), interpolation=cv2.INTER_AREA)
    return img if bgr else np.ascontiguousarray(img[..., ::-1])


def read_image_float(path: str | os.PathLike, *, size: tuple[int, int] | None = None,
                     fix: str | None = None) -> np.ndarray:
    """[H, W, 3] float32 RGB in [0, 1] of an image file (see :func:`read_image`)."""
    return read_image(path, size=size, fix=fix).astype(np.float32) / 255.0


def read_image_as_stored(path: str | os.PathLike, *, fix: str | None = None) -> np.ndarray:
    """The image file's array as stored: [H, W] or [H, W, C] (BGR(A) channel order), any
    bit depth, alpha kept (hand-made masks); errors as :func:`read_image`."""
    import cv2

    return _imread(path, cv2.IMREAD_UNCHANGED, fix)


def read_gray(path: str | os.PathLike, *, fix: str | None = None) -> np.ndarray:
    """[H, W] uint8 grey levels of an image file (masks); errors as :func:`read_image`."""
    import cv2

    return _imread(path, cv2.IMREAD_GRAYSCALE, fix)


def image_size(path: str | os.PathLike, *, fix: str | None = None) -> tuple[int, int]:
    """(height, width) of an image file."""
    return read_image(path, bgr=True, fix=fix).shape[:2]


def put_label(img: np.ndarray, label: str, scale: float = 0.5, min_scale: float = 0.3,
              bottom: bool = False) -> None:
    """Write ``label`` white, outlined in black, at the top left of ``img`` (at its bottom
    left with ``bottom``; an 8-bit image, in place), smaller down to ``min_scale`` where it
    is wider than ``img``, then shortened in the middle."""
    import cv2

    font, room = cv2.FONT_HERSHEY_SIMPLEX, img.shape[1] - 10

    def width(text: str, sc: float) -> int:
        return cv2.getTextSize(text, font, sc, 1)[0][0]

    if width(label, scale) > room:
        scale = max(min_scale, scale * room / width(label, scale))
    full, keep = label, len(label)
    while keep > 4 and width(label, scale) > room:
        keep -= 1
        label = full[:keep // 2] + ".." + full[len(full) - (keep - keep // 2):]
    y = img.shape[0] - 7 if bottom else 7 + cv2.getTextSize(label, font, scale, 1)[0][1]
    # the outline grown from the glyphs themselves: a Hershey font's advance grows with the
    # stroke's thickness, so a thick black pass drawn under a thin white one drifts from it
    glyphs = np.zeros(img.shape[:2], np.uint8)
    cv2.putText(glyphs, label, (5, y), font, scale, 255, 1)
    img[cv2.dilate(glyphs, np.ones((3, 3), np.uint8)) > 0] = 0
    img[glyphs > 0] = 255
