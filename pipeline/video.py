"""H.264 video writer: raw RGB frames piped to the ffmpeg bundled in the imageio-ffmpeg wheel.

The PyPI OpenCV wheels cannot encode H.264; the imageio-ffmpeg wheel ships an ffmpeg binary
with libx264 (``imageio_ffmpeg.get_ffmpeg_exe()``), so nothing is downloaded at run time and
no system tool is called. Output: libx264, yuv420p (plays everywhere), even width and height
(odd sizes are padded by repeating the last row / column), ``+faststart``. The file is
written to a temporary name and renamed into place.
"""

from __future__ import annotations

import os
import subprocess
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from pipeline.workspace import atomic_path


def ffmpeg_exe() -> str:
    """Path of the bundled ffmpeg binary."""
    import imageio_ffmpeg

    return imageio_ffmpeg.get_ffmpeg_exe()


def even_pad(rgb: np.ndarray) -> np.ndarray:
    """[H, W, 3] uint8 -> the same padded to even H and W (edge rows / columns repeated)."""
    h, w = rgb.shape[:2]
    if h % 2 == 0 and w % 2 == 0:
        return rgb
    return np.pad(rgb, ((0, h % 2), (0, w % 2), (0, 0)), mode="edge")


def write_video(path: str | os.PathLike, frames: Iterable[np.ndarray], fps: float = 24.0,
                crf: int = 18, preset: str = "medium") -> Path:
    """Encode RGB uint8 frames [H, W, 3] (all one size) to an H.264 mp4 at ``path``.

    ``crf``: x264 constant rate factor, 0 (lossless) .. 51 (worst); 18 is visually lossless.
    Returns ``path``. Raises ``ValueError`` for no frames or frames of different sizes.
    """
    path = Path(path)
    it = iter(frames)
    first = next(it, None)
    if first is None:
        raise ValueError("no frames to encode")
    first = even_pad(np.ascontiguousarray(first[..., :3], np.uint8))
    h, w = first.shape[:2]
    with atomic_path(path) as tmp:
        cmd = [ffmpeg_exe(), "-hide_banner", "-loglevel", "error", "-y",
               "-f", "rawvideo", "-pix_fmt", "rgb24", "-s", f"{w}x{h}", "-r", f"{fps:g}",
               "-i", "-", "-an", "-c:v", "libx264", "-preset", preset, "-crf", str(int(crf)),
               "-pix_fmt", "yuv420p", "-movflags", "+faststart", str(tmp)]
        proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stderr=subprocess.PIPE)
        try:
            _feed(proc, first, it, (h, w))
        except BaseException:
            proc.kill()
            proc.wait()
            raise
        err = proc.stderr.read().decode(errors="replace")
        if proc.wait() != 0:
            raise RuntimeError(f"ffmpeg failed writing {path}: {err.strip()[-500:]}")
    return path


def _feed(proc: subprocess.Popen, first: np.ndarray, rest, size: tuple[int, int]) -> None:
    proc.stdin.write(first.tobytes())
    for frame in rest:
        frame = even_pad(np.ascontiguousarray(frame[..., :3], np.uint8))
        if frame.shape[:2] != size:
            raise ValueError(f"frame of size {frame.shape[1]}x{frame.shape[0]} in a video of "
                             f"{size[1]}x{size[0]}")
        proc.stdin.write(frame.tobytes())
    proc.stdin.close()


def read_frames_cv2(path: str | os.PathLike) -> list[np.ndarray]:
    """Decode a video with OpenCV: list of BGR frames (for checks and tests)."""
    from pipeline.video_input import frames

    return list(frames(Path(path)))
