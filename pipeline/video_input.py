"""Frames of a video in the photo folder: the views the decode stage takes from it.

A walk around a scene filmed with a phone is as good a capture as photos once its frames are
chosen well. Two things spoil frames: motion blur (a frame taken while the camera swung) and
repetition (the camera held still, so many frames show one view). The choice, in two
sequential passes over the video (seeking is not frame-exact in every container):

1. *Scan*: every frame, reduced to grey, gives its sharpness (the variance of the Laplacian
   at ``SHARP_SIZE`` pixels on the long side) and its change from the frame before (the mean
   absolute difference at ``MOTION_SIZE`` pixels, area-averaged so sensor noise cancels): how
   far the view moved.
2. *Choose*: the video's accumulated change is cut into ``count`` stretches of equal change
   (a pause adds nothing, so it gets no stretch of its own; a video with no change at all is
   cut by time) and each stretch gives its sharpest frame. A jump longer than a stretch (a
   video of few frames) leaves stretches empty: the widest gaps between the frames taken
   then give theirs, until ``count`` are taken.
3. *Read*: the chosen frames are decoded again (OpenCV's FFmpeg, which applies the video's
   rotation) and handed to the decode stage, which resizes and writes them like photos.

Each chosen frame becomes a view named ``<video stem>_f<frame index, 5 digits>``.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

VIDEO_EXTS = frozenset({".mp4", ".mov", ".m4v", ".avi", ".mkv", ".mts", ".m2ts", ".webm",
                        ".3gp", ".wmv"})
SHARP_SIZE = 640
"""Long side, in pixels, at which a frame's sharpness is measured."""
MOTION_SIZE = 96
"""Long side, in pixels, at which the change between frames is measured."""


class VideoError(Exception):
    """A video that cannot be read (corrupt, unsupported, no frames)."""


def is_video(path: str | os.PathLike) -> bool:
    """A file name with a video extension (any case)."""
    return Path(path).suffix.lower() in VIDEO_EXTS


def frame_stem(video: Path, index: int) -> str:
    """The view name of frame ``index`` of ``video``."""
    return f"{video.stem}_f{index:05d}"


def view_label(stem: str, source: str | None) -> str:
    """How messages name a view: its photo's file name, or ``<stem> (<video>)`` for a
    video's frame (``source``: decode's record of the file it came from)."""
    if source is None:
        return f"{stem}.png"
    return f"{stem} ({source})" if is_video(source) else source


@dataclass
class Scan:
    """What the first pass measured: one entry per frame."""

    sharpness: np.ndarray
    """[N] variance of the Laplacian of the grey frame at ``SHARP_SIZE``."""
    change: np.ndarray
    """[N] mean absolute grey difference from the frame before at ``MOTION_SIZE`` (0 for
    the first frame), on a 0-255 scale."""
    fps: float
    size: tuple[int, int]
    """(width, height) of the decoded frames (rotation applied)."""


def _shrink(gray: np.ndarray, long_side: int) -> np.ndarray:
    import cv2

    h, w = gray.shape
    s = min(1.0, long_side / max(h, w))
    if s >= 1.0:
        return gray.astype(np.float32)
    size = (max(1, round(w * s)), max(1, round(h * s)))
    return cv2.resize(gray, size, interpolation=cv2.INTER_AREA).astype(np.float32)


def frame_measures(bgr: np.ndarray) -> tuple[float, np.ndarray]:
    """(sharpness, small grey frame for the change) of one BGR frame."""
    import cv2

    gray = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY) if bgr.ndim == 3 else bgr
    sharp = float(cv2.Laplacian(_shrink(gray, SHARP_SIZE), cv2.CV_32F).var())
    return sharp, _shrink(gray, MOTION_SIZE)


def _open(path: Path):
    import cv2

    from pipeline.progress import quiet_stderr

    cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_ERROR)
    with quiet_stderr():  # FFmpeg's own lines about a bad header: the stage names the file
        cap = cv2.VideoCapture(str(path), cv2.CAP_FFMPEG)
    if not cap.isOpened():
        raise VideoError("not a readable video (corrupt or unsupported)")
    return cap


def _read(cap) -> Iterator[np.ndarray]:
    """Every frame left in an open capture, in order (BGR uint8); releases it."""
    try:
        while True:
            ok, frame = cap.read()
            if not ok:
                return
            yield frame
    finally:
        cap.release()


def frames(path: Path) -> Iterator[np.ndarray]:
    """Every frame of the video, decoded in order (BGR uint8)."""
    return _read(_open(path))


def scan(path: Path, advance: Callable[[], None] = lambda: None,
         on_count: Callable[[int], None] = lambda n: None) -> Scan:
    """First pass: sharpness and change of every frame (``advance`` after each), from one
    opening of the file; ``on_count`` first gets the container's frame count (an estimate
    in some containers, 0 when unknown), e.g. for a progress bar."""
    import cv2

    cap = _open(path)
    on_count(max(0, int(cap.get(cv2.CAP_PROP_FRAME_COUNT))))
    fps = float(cap.get(cv2.CAP_PROP_FPS)) or 0.0
    sharp, change, prev, size = [], [], None, (0, 0)
    for bgr in _read(cap):
        s, small = frame_measures(bgr)
        sharp.append(s)
        change.append(0.0 if prev is None or prev.shape != small.shape
                      else float(np.abs(small - prev).mean()))
        prev, size = small, (bgr.shape[1], bgr.shape[0])
        advance()
    if not sharp:
        raise VideoError("no frames could be decoded (corrupt or unsupported)")
    return Scan(np.asarray(sharp), np.asarray(change), fps, size)


def choose(s: Scan, count: int) -> list[int]:
    """Indices (ascending) of ``min(count, frames)`` frames: the sharpest frame of each of
    ``count`` stretches of equal accumulated change (equal time when nothing changes), then
    of the widest gaps between them while stretches were empty."""
    n = len(s.sharpness)
    if count >= n:
        return list(range(n))
    travel = np.cumsum(s.change)
    if travel[-1] <= 1e-6:  # a still video: cut by time
        travel = np.arange(1, n + 1, dtype=np.float64)
    edges = np.linspace(0.0, float(travel[-1]), count + 1)
    stretch = np.minimum(np.searchsorted(edges, travel, side="left") - 1, count - 1)
    stretch = np.maximum(stretch, 0)
    chosen = set()
    for k in range(count):
        members = np.flatnonzero(stretch == k)
        if len(members):  # a jump longer than a stretch leaves one without frames
            chosen.add(int(members[np.argmax(s.sharpness[members])]))
    while len(chosen) < count:  # then the widest gap gives its sharpest frame
        ends = [-1, *sorted(chosen), n]
        a, b = max(zip(ends[:-1], ends[1:], strict=True), key=lambda ab: ab[1] - ab[0])
        inside = np.arange(a + 1, b)
        chosen.add(int(inside[np.argmax(s.sharpness[inside])]))
    return sorted(chosen)


def read_chosen(path: Path, chosen: list[int],
                advance: Callable[[], None] = lambda: None) -> Iterator[tuple[int, np.ndarray]]:
    """Second pass: (index, BGR frame) of the ``chosen`` frames, in order (``advance``
    after each frame read, chosen or not)."""
    want = set(chosen)
    last = max(chosen) if chosen else -1
    for i, bgr in enumerate(frames(path)):
        if i in want:
            yield i, bgr
        advance()
        if i >= last:
            return
