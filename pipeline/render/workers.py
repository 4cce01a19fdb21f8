"""Rendering the frame jobs: in this process, or on the CPU split over one-thread processes.

A frame's GN-FR rays are many small products (a chunk of 256 rays is a few thousand rows of
32 channels): on the CPU torch's threads share them poorly, so on the 2-core machine two
processes of one thread, each rendering every other frame, finish a video 1.4x sooner than
one process with two threads (``benchmarks/render_workers.py``). Every process loads the
model, encodes the same source views (the whole job list's, so each frame sees the sources
it would in one process) and writes its frames atomically as the single process does: the
frames are the same, and an interrupted render resumes from the frames on disk.
"""

from __future__ import annotations

import contextlib
import os
import time
from dataclasses import dataclass
from pathlib import Path

from pipeline.cameras import Cameras
from pipeline.progress import make_progress
from pipeline.render.config import RenderConfig
from pipeline.render.engine import render_jobs
from pipeline.render.fill import photo_views
from pipeline.render.jobs import FrameJob
from pipeline.render.sources import encode_sources, load_model
from pipeline.workspace import Workspace

MIN_FRAMES_PER_WORKER = 2
"""Below this many frames per process the processes' start (torch's import, the model, the
sources' encoding: a few seconds each) outweighs what they save: fewer processes are used."""


AUTO_WORKERS = True
"""Whether ``RenderConfig.workers`` unset means one process per torch thread (True) or this
process alone. The test suite sets it False: its counters and simulated interrupts patch
functions of this process, which a spawned worker would not see; its tests of the workers
ask for them by ``workers``."""


@dataclass(frozen=True)
class RenderSetup:
    """What every rendering process needs besides its jobs (picklable)."""

    ws: Workspace
    ckpt: Path
    cfg: RenderConfig
    params: dict
    device: str
    stems: list[str]
    """The source views to encode: every job's, whichever process renders it."""
    gains: dict | None
    use_photos: bool
    frames_maps: bool


def frame_workers(cfg: RenderConfig, device: str, n_jobs: int) -> int:
    """How many processes render ``n_jobs`` frames: ``cfg.workers`` when given, else one per
    thread torch uses on the CPU (``AUTO_WORKERS``); never more than ``n_jobs /
    MIN_FRAMES_PER_WORKER``, and 1 on CUDA or with ``cfg.compile`` (each process would
    compile again)."""
    if device.startswith("cuda") or cfg.compile:
        return 1
    if cfg.workers is not None:
        want = int(cfg.workers)
    elif AUTO_WORKERS:
        import torch

        want = torch.get_num_threads()
    else:
        want = 1
    return max(1, min(want, n_jobs // MIN_FRAMES_PER_WORKER))


def render_here(setup: RenderSetup, cams: Cameras, jobs: list[FrameJob],
                quiet: bool = False) -> None:
    """Render ``jobs`` in this process with torch's threads."""
    import torch

    with torch.inference_mode():
        model = load_model(setup.ckpt, setup.device)
        src, index = encode_sources(model, setup.ws, cams, setup.stems, setup.device,
                                    setup.params["source_scale"],
                                    setup.params["full_res_colour"], setup.gains)
        photos = (photo_views(setup.ws, cams, jobs, setup.cfg, setup.frames_maps)
                  if setup.use_photos else None)
        if setup.cfg.compile:  # after encoding: only the rays' forward pass is compiled
            model = torch.compile(model, dynamic=False)
        render_jobs(model, src, index, jobs, setup.params, setup.cfg, setup.ws, photos,
                    setup.gains, quiet=quiet)


ONE_THREAD_ENV = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
"""Variables a worker starts with at 1, so that the libraries that read them when they load
(OpenMP, numpy's BLAS) keep to one thread; OMP_WAIT_POLICY comes with the parent's
environment (workflows/threads.py)."""


def _one_thread() -> None:
    """A worker's initializer: torch and OpenCV on one thread (OpenCV's own pool would
    otherwise take every core in each process: the processes then ran a frame hardly faster
    than one process with two threads)."""
    import cv2
    import torch

    torch.set_num_threads(1)
    cv2.setNumThreads(1)


@contextlib.contextmanager
def one_thread_env():
    """``ONE_THREAD_ENV`` at 1 in this process's environment while the workers start (they
    inherit it), restored after."""
    old = {k: os.environ.get(k) for k in ONE_THREAD_ENV}
    os.environ.update({k: "1" for k in ONE_THREAD_ENV})
    try:
        yield
    finally:
        for k, v in old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def _render_part(setup: RenderSetup, jobs: list[FrameJob]) -> int:
    """A worker process's share (its thread count set by the pool's initializer)."""
    from pipeline.ws_files import read_cameras

    render_here(setup, read_cameras(setup.ws), jobs, quiet=True)
    return len(jobs)


def render_in_workers(setup: RenderSetup, jobs: list[FrameJob], workers: int) -> None:
    """Render ``jobs`` in ``workers`` spawned one-thread processes, job i in process
    i mod ``workers``, with one progress bar of the frames written. A worker's error is
    raised here; an interrupt (Ctrl-C, SIGTERM) stops every worker, the frames written so
    far stay."""
    import multiprocessing as mp

    with one_thread_env():  # the processes start here and inherit it
        pool = mp.get_context("spawn").Pool(workers, initializer=_one_thread)
    try:
        results = [pool.apply_async(_render_part, (setup, jobs[i::workers]))
                   for i in range(workers)]
        pool.close()
        with make_progress() as prog:
            task = prog.add_task(f"frames ({workers} processes)", total=len(jobs))
            while True:
                prog.update(task, completed=sum(j.out.exists() for j in jobs))
                for r in results:
                    if r.ready() and not r.successful():
                        r.get()  # the worker's exception, raised here
                if all(r.ready() for r in results):
                    break
                time.sleep(0.25)
        pool.join()
    finally:
        pool.terminate()
        pool.join()
