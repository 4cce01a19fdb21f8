"""Rendering the frame jobs: in this process, or on the CPU split over one-thread processes.

A frame's GN-FR rays are many small products (a chunk of 256 rays is some 40 000 rows of
32 channels): on the CPU torch's threads share them poorly, so on the 2-core machine two
processes of one thread, each rendering every other frame, finish a video 1.3x sooner than
one process with two threads (``benchmarks/render_speed.py``, docs/performance.md). Every
process loads the model, encodes the same source views (the whole job list's, so each frame
sees the sources it would in one process) and writes its frames atomically as the single
process does: the frames are the same but for the rounding of sums taken in another order
(a few values in a million one level apart), and an interrupted render resumes from the
frames on disk.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from pathlib import Path

from pipeline.cameras import Cameras
from pipeline.progress import make_progress
from pipeline.render.config import RenderConfig
from pipeline.render.engine import render_jobs
from pipeline.render.fill import photo_views
from pipeline.render.jobs import FrameJob
from pipeline.render.sources import encode_sources, load_model, with_deflared
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
    """The exposure the model was trained at (the checkpoint's ``exposure_gains``)."""
    deflared: tuple[float, float] | None = None
    """With ``RenderConfig.from_deflared`` or ``lean_deflared``: the de-flared photos' blend
    (dilate, feather), by which GN-FR's sources (``from_deflared``) or the photos a frame
    leans to (``lean_deflared``) read their flare regions from them."""

    @property
    def use_photos(self) -> bool:
        """The hybrid fill warps the photos (``run`` has turned it to ``network`` where the
        workspace has no depth maps)."""
        return self.cfg.fill == "hybrid"

    @property
    def frames_maps(self) -> bool:
        """Novel frames warp through the depth stage's maps for them (``WS/depth/frames``)."""
        return self.params.get("depth_maps") == "frames"


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
                                    setup.params["full_res_colour"], setup.gains,
                                    setup.params["encode_apart"],
                                    setup.deflared if setup.cfg.from_deflared else None,
                                    setup.cfg.source_grow)
        lean = (partial(with_deflared, setup.ws, dilate=setup.deflared[0],
                        feather=setup.deflared[1])  # the photos a frame leans to, de-flared
                if setup.cfg.lean_deflared and setup.deflared is not None else None)
        photos = (photo_views(setup.ws, cams, jobs, setup.cfg, setup.frames_maps, lean)
                  if setup.use_photos else None)
        if setup.cfg.compile:  # after encoding: only the rays' forward pass is compiled
            model = torch.compile(model, dynamic=False)
        render_jobs(model, src, index, jobs, setup.params, setup.cfg, setup.ws, photos,
                    setup.gains, quiet=quiet)


def _one_thread() -> None:
    """A worker's first step: torch and OpenCV on one thread (OpenCV's own pool would
    otherwise take every core in each process: the processes then ran a frame hardly faster
    than one process with two threads)."""
    import cv2
    import torch

    torch.set_num_threads(1)
    cv2.setNumThreads(1)


def _worker_main(setup: RenderSetup, jobs: list[FrameJob], index: int, results) -> None:
    """A worker process: one thread, its share of the jobs, then ``(index, error or None)``
    on the ``results`` queue (an error that does not pickle is sent as its text)."""
    import pickle
    import traceback

    from gnfr.malloc import keep_freed_memory
    from pipeline.errors import UserError
    from pipeline.ws_files import read_cameras

    _one_thread()
    keep_freed_memory()
    try:
        render_here(setup, read_cameras(setup.ws), jobs, quiet=True)
    except KeyboardInterrupt:  # Ctrl-C reaches every process: the parent reports it
        return
    except Exception as e:  # noqa: BLE001 (sent to the parent, which raises it)
        if not isinstance(e, UserError):
            e = RuntimeError(f"a render process failed: {type(e).__name__}: {e}\n"
                             f"{traceback.format_exc()}")
        try:
            pickle.dumps(e)
        except Exception:  # noqa: BLE001
            e = RuntimeError(f"a render process failed: {e}")
        results.put((index, e))
        return
    results.put((index, None))


def render_in_workers(setup: RenderSetup, jobs: list[FrameJob], workers: int,
                      target=_worker_main) -> None:
    """Render ``jobs`` in ``workers`` spawned one-thread processes, job i in process
    i mod ``workers``, with one progress bar of the frames written. A worker's error is
    raised here; a worker that dies without a word (killed for memory) is a one-line
    UserError; an interrupt (Ctrl-C, SIGTERM) stops every worker. The frames written so far
    stay either way (a rerun resumes). ``target``: the workers' function (tests)."""
    import multiprocessing as mp
    import queue

    from gnfr.ray_split import threads_env
    from pipeline.errors import UserError

    ctx = mp.get_context("spawn")
    results = ctx.Queue()
    procs = [ctx.Process(target=target, args=(setup, jobs[i::workers], i, results),
                         daemon=True) for i in range(workers)]
    finished: set[int] = set()

    def collect(wait: float) -> None:
        while True:
            try:
                index, error = results.get(timeout=wait)
            except queue.Empty:
                return
            if error is not None:
                raise error
            finished.add(index)
            wait = 0.0

    try:
        with threads_env(1):  # the processes start here and inherit it (OMP, BLAS)
            for p in procs:
                p.start()
        with make_progress() as prog:
            task = prog.add_task(f"frames ({workers} processes)", total=len(jobs))
            while len(finished) < workers:
                collect(0.25)
                prog.update(task, completed=sum(j.out.exists() for j in jobs))
                dead = [i for i, p in enumerate(procs)
                        if i not in finished and p.exitcode is not None]
                if dead:
                    collect(0.5)  # a result sent just before the process ended
                    dead = [i for i in dead if i not in finished]
                if dead:
                    code = procs[dead[0]].exitcode
                    raise UserError(
                        f"render: a frame process stopped without finishing (exit code {code}"
                        f"{', killed: out of memory?' if code and code < 0 else ''}); the "
                        "frames written so far are kept: rerun to resume, with `--set "
                        "render.workers=1` to render in one process (less memory)")
    finally:
        for p in procs:
            if p.is_alive():
                p.terminate()
        for p in procs:
            p.join()
