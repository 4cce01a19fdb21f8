"""`deflare-scene bench`: training and rendering speed and peak memory, fast vs reference.

Runs anywhere without data: a synthetic scene (smooth random textures on a ring of cameras
looking at the origin, a flare blob in every third view) is built in memory. For each
device (CPU, and CUDA when present) it measures, in the same process and run:

- training iterations/s at a preset (default ``quick``) in three modes: end-to-end (the
  encoder trained, sources encoded every step), cached features (frozen encoder, sources
  encoded once) and the plain reference path (end-to-end, fp32, no fused attention); on
  the CPU a fourth, end-to-end with every step shared by one-thread processes as the
  fine-tune does by default there (``gnfr.ray_split``; its peak memory is the first
  process's alone);
- rendering seconds per frame at 504x378 and 1008x756: fast = the render stage's path
  (sources encoded once and shared by all frames, bf16 autocast and fused attention on
  CUDA, bf16 on the CPU where the stage's default uses it, ``gnfr.renderer.cpu_bf16``;
  the training modes but ``reference`` follow the fine-tune's the same way), reference =
  sources re-encoded for every frame, fp32, no fused attention. Rays are timed on ``rays``
  pixels of the frame (default: all of it on CUDA, 4096 on CPU) and scaled to the whole
  frame (cost is linear in rays: fixed chunks);
- peak memory of each measurement: CUDA ``torch.cuda.max_memory_allocated``; CPU the peak
  resident set size above the level at the start of the measurement, sampled every 5 ms
  (psutil when installed, else /proc/self/statm, else ``resource`` maxrss).

With ``workspace`` (a workspace with a fine-tuned model and WS/depth, e.g. the sample's after
the one-shot) it also times what a user's video costs: frames of the workspace's
interpolate path, 504 and 1008 px wide, rendered by the render stage itself with GN-FR
alone (every pixel, uniform samples) and with the default hybrid fill (photos warped by
depth, GN-FR on the rest with depth-guided samples), in the same run. The stage runs in a
scratch workspace of hard links; the given workspace is only read.
"""

from __future__ import annotations

import contextlib
import math
import os
import threading
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from pipeline.options import option

SIZES = ((504, 378), (1008, 756))
FILL_WIDTHS = (504, 1008)
"""Frame widths of the workspace measurement (the path camera's aspect is kept)."""


@dataclass
class BenchConfig:
    """Options of `deflare-scene bench`."""

    out: Path = Path("bench.json")
    """JSON file to write."""
    devices: tuple[str, ...] = ()
    """Devices to measure (default: cpu, and cuda when present)."""
    preset: str = "quick"
    """Training preset whose model, rays and samples are measured."""
    steps: int = option(10, ge=1)
    """Timed training steps per mode (after ``warmup``)."""
    warmup: int = option(2, ge=0)
    """Untimed steps (and render passes) before timing."""
    rays: int | None = option(None, ge=1)
    """Rays timed per rendered frame (default: the whole frame on CUDA, 4096 on CPU)."""
    samples: int | None = option(None, ge=1)
    """Samples per ray when rendering (default: the preset's)."""
    views: int = option(10, ge=3)
    """Views of the synthetic scene (training sources come from these)."""
    train_size: tuple[int, int] = option((504, 378), ge=8, sep="x", metavar="WIDTHxHEIGHT")
    """Image size (width, height) of the synthetic training views."""
    chunk: int | None = option(None, ge=1)
    """Rays per forward pass when rendering (default: the render stage's for the device)."""
    repeats: int = option(2, ge=1)
    """Render passes per path, alternating fast and reference; the fastest of each counts."""
    isolate: bool = True
    """CPU: run each measurement in a fresh process, so its peak RSS is its own (the
    allocator keeps memory freed by an earlier measurement)."""
    workspace: Path | None = None
    """Also time novel frames of this workspace's video path (it needs WS/model and
    WS/depth, e.g. samples/cyprus.deflare after the one-shot): GN-FR alone beside the
    hybrid fill, 504 and 1008 px wide. Only read: the render runs in a scratch copy."""
    fill_frames: int = option(1, ge=1)
    """Frames of the path timed per width and fill (``workspace``)."""
    fill_only: bool = False
    """Only the novel frames of ``workspace`` (skips the synthetic training and render
    measurements: minutes instead of a quarter of an hour on a CPU)."""
    quick: bool = False
    """A small fast run (tests): 2 steps, 1 warm-up, 128 rays, 8 samples per frame, no
    process isolation (CPU peak memory then depends on the order of measurements),
    workspace frames 48 and 96 px wide."""


def effective(cfg: BenchConfig) -> BenchConfig:
    if not cfg.quick:
        return cfg
    return replace(cfg, steps=min(cfg.steps, 2), warmup=1, rays=cfg.rays or 128,
                   samples=cfg.samples or 8, views=min(cfg.views, 8), train_size=(252, 189),
                   isolate=False, repeats=1)


# --------------------------------------------------------------------------- machine
def machine() -> dict:
    """The machine the numbers were taken on (``pipeline.provenance.machine``)."""
    from pipeline.provenance import machine as provenance_machine

    return provenance_machine()


# --------------------------------------------------------------------------- memory
def _rss_bytes() -> int | None:
    try:
        import psutil

        return int(psutil.Process().memory_info().rss)
    except ImportError:
        pass
    try:
        pages = int(Path("/proc/self/statm").read_text().split()[1])
        return pages * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return None


def memory_method(device: str) -> str:
    """How PeakMemory measures on ``device`` (recorded in the JSON)."""
    if device == "cuda":
        return "torch.cuda.max_memory_allocated - allocated at start"
    try:
        import psutil  # noqa: F401

        return "peak RSS (psutil) sampled every 5 ms - RSS at start"
    except ImportError:
        pass
    if _rss_bytes() is not None:
        return "peak RSS (/proc/self/statm) sampled every 5 ms - RSS at start"
    return "resource maxrss delta (0 unless the process peak grows)"


class PeakMemory:
    """Context manager measuring peak memory above the start level, in MiB (``.mib``)."""

    def __init__(self, device: str):
        self.device, self.mib, self.how = device, 0.0, ""

    def __enter__(self) -> PeakMemory:
        import torch

        if self.device == "cuda":
            torch.cuda.synchronize()
            torch.cuda.reset_peak_memory_stats()
            self.start = torch.cuda.memory_allocated()
            self.how = "torch.cuda.max_memory_allocated - allocated at start"
            return self
        self.start = _rss_bytes()
        if self.start is None:
            import resource

            self.start = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
            self.how = "resource maxrss delta (0 unless the process peak grows)"
            self._thread = None
            return self
        self.how = "peak RSS sampled every 5 ms - RSS at start"
        self.peak, self._stop = self.start, threading.Event()

        def poll():
            while not self._stop.wait(0.005):
                self.peak = max(self.peak, _rss_bytes() or 0)

        self._thread = threading.Thread(target=poll, daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        import torch

        if self.device == "cuda":
            torch.cuda.synchronize()
            self.mib = (torch.cuda.max_memory_allocated() - self.start) / 2**20
        elif self._thread is None:
            import resource

            peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
            self.mib = max(0, peak - self.start) / 2**20
        else:
            self._stop.set()
            self._thread.join()
            self.peak = max(self.peak, _rss_bytes() or 0)
            self.mib = (self.peak - self.start) / 2**20


def _sync(device: str) -> None:
    import torch

    if device == "cuda":
        torch.cuda.synchronize()


# --------------------------------------------------------------------------- scene
def synthetic_scene(n: int, size: tuple[int, int], seed: int = 0):
    """A gnfr.train.Scene of ``n`` views [W, H] = ``size`` on an arc looking at the origin:
    smooth random textures, a round flare blob in every third view."""
    import cv2

    from gnfr.paths import look_at
    from pipeline.training_scenes import make_scene

    W, H = size
    rng = np.random.default_rng(seed)
    th = np.linspace(-0.5, 0.5, n)
    c2w = np.stack([look_at(np.array([np.sin(t), 0.0, -np.cos(t)]) * 2.5, np.zeros(3),
                            np.array([0.0, -1.0, 0.0])) for t in th])
    K = np.array([[0.9 * W, 0, W / 2], [0, 0.9 * W, H / 2], [0, 0, 1.0]])
    images, masks = [], []
    for i in range(n):
        small = rng.random((H // 8, W // 8, 3))
        img = cv2.resize(small, (W, H), interpolation=cv2.INTER_CUBIC)
        images.append(np.clip(img * 255, 0, 255).astype(np.uint8))
        m = np.zeros((H, W), np.uint8)
        if i % 3 == 0:
            cv2.circle(m, (int(rng.integers(W)), int(rng.integers(H))), H // 6, 1, -1)
        masks.append(m.astype(bool))
    return make_scene("bench", [f"v{i:02d}" for i in range(n)], images, np.repeat(K[None], n, 0),
                      c2w, np.full(n, 1.0), np.full(n, 4.5), masks)


# --------------------------------------------------------------------------- training
TRAIN_MODES = {"end_to_end": {"cached_features": False, "reference": False},
               "cached": {"cached_features": True, "reference": False},
               "reference": {"cached_features": False, "reference": True},
               "processes": {"cached_features": False, "reference": False}}
"""reference = the plain fp32 path, end-to-end (no cached features, no fused attention);
processes = end-to-end with each step shared by one-thread processes as the fine-tune does
on the CPU by default (``gnfr.ray_split``, ``split_processes``; CPU only)."""


def split_processes(tcfg) -> int:
    """Processes of the ``processes`` mode: one per torch thread, at least 2 and at most
    the fine-tune's ``MAX_AUTO_WORKERS``, fewer where a process would get under
    ``gnfr.ray_split.MIN_RAYS`` rays (then 1: the mode is skipped)."""
    import torch

    from gnfr.ray_split import parts
    from pipeline.finetune import MAX_AUTO_WORKERS

    return parts(tcfg.rays, max(2, min(MAX_AUTO_WORKERS, torch.get_num_threads())))


def bench_train(cfg: BenchConfig, tcfg, scene, device: str, mode: str) -> dict:
    """Training it/s and peak memory of one mode."""
    import torch

    from gnfr.fit import StepInput, Trainer
    from gnfr.model import GNFR
    from gnfr.renderer import cpu_bf16
    from gnfr.train import prepare_sources, sample_batch

    train_cfg = replace(tcfg, **TRAIN_MODES[mode])
    if not train_cfg.reference:  # as the fine-tune trains by default on this device
        train_cfg = replace(train_cfg, cpu_bf16=cpu_bf16(None, device))
    torch.manual_seed(0)
    model = GNFR(train_cfg.model).to(device)
    trainer = Trainer(model, train_cfg, gen=torch.Generator().manual_seed(0))
    n = split_processes(train_cfg) if mode == "processes" else 1
    with contextlib.ExitStack() as stack:
        mem = stack.enter_context(PeakMemory(device))
        t0 = time.perf_counter()
        bank, cache = prepare_sources(model, scene, train_cfg, torch.device(device))
        split = None
        if n > 1:
            from gnfr.ray_split import RaySplit
            from pipeline.finetune import torch_threads

            stack.enter_context(torch_threads(1))
            split = stack.enter_context(RaySplit(model, [(bank, cache)], train_cfg, n))
        _sync(device)
        prep = time.perf_counter() - t0
        for _ in range(cfg.warmup + (n > 1)):  # and the helpers' start
            trainer.train_one(StepInput(sample_batch(scene, train_cfg, trainer.gen), bank,
                                        cache), split=split)
        _sync(device)
        t0 = time.perf_counter()
        for _ in range(cfg.steps):
            trainer.train_one(StepInput(sample_batch(scene, train_cfg, trainer.gen), bank,
                                        cache), split=split)
        _sync(device)
        dt = time.perf_counter() - t0
    out = {"it_per_s": cfg.steps / dt, "s_per_it": dt / cfg.steps, "prepare_s": prep,
           "peak_mib": mem.mib, "steps": cfg.steps, "cpu_bf16": train_cfg.cpu_bf16}
    if n > 1:
        out.update(processes=n, threads_each=1,
                   peak_mib_note="this process's alone: each helper holds its own torch")
    return out


# --------------------------------------------------------------------------- rendering
def _frame_rays(W: int, H: int, n_rays: int, c2w, device: str):
    """(K [3, 3], rays_o [R, 3], rays_d [R, 3]) of ``n_rays`` pixels spread over a frame."""
    import torch

    from gnfr.geometry import image_pixels, pixel_rays

    K = torch.tensor([[0.9 * W, 0, W / 2], [0, 0.9 * W, H / 2], [0, 0, 1.0]])
    pix = image_pixels(H, W)
    if n_rays < len(pix):
        g = torch.Generator().manual_seed(0)
        pix = pix[torch.randperm(len(pix), generator=g)[:n_rays]]
    o, d = pixel_rays(K, c2w, pix)
    return K, o.to(device), d.to(device)


def _sources(scene, train_cfg, size: tuple[int, int], n: int):
    """First ``n`` scene views resized to ``size`` x source_scale: images, K, masks, c2w."""
    import torch
    import torch.nn.functional as F

    W, H = size
    w, h = max(8, round(W * train_cfg.source_scale)), max(8, round(H * train_cfg.source_scale))
    imgs = F.interpolate(scene.images[:n].float() / 255, size=(h, w), mode="area")
    masks = F.interpolate(scene.masks[:n].float(), size=(h, w), mode="area").round()
    K = torch.tensor([[0.9 * w, 0, w / 2], [0, 0.9 * w, h / 2], [0, 0, 1.0]]).expand(n, 3, 3)
    return imgs, K.contiguous(), masks, scene.c2w[:n].float()


@dataclass
class _FrameRays:
    """What one frame's rendering is timed on: a model, the encoded sources' inputs and
    ``R`` rays of the frame, each timed pass rendering them all."""

    model: object
    sources: tuple  # images, K, masks, c2w (``_sources``)
    o: object
    d: object
    near: object
    far: object
    ids: object
    samples: int
    chunk: int
    bf16: bool
    device: str

    def encode(self, grad: bool = False):
        from gnfr.renderer import SourceViews

        imgs, K, masks, c2w = self.sources
        return SourceViews.encode(self.model, imgs, K, c2w, masks, self.device, grad=grad)

    def fast(self, src, rays: slice = slice(None)) -> None:
        """The render stage's path: ``render_rays`` on sources encoded once."""
        from gnfr.renderer import render_rays

        render_rays(self.model, src, self.ids, self.o[rays], self.d[rays], self.near[rays],
                    self.far[rays], self.samples, chunk=self.chunk, cpu_bf16=self.bf16)

    def reference(self, src, rays: slice = slice(None)) -> None:
        """The plain path: fp32, plain attention, chunk by chunk."""
        from gnfr.geometry import sample_depths
        from gnfr.renderer import forward_rays

        idx = range(len(self.o))[rays]
        for i in range(idx.start, idx.stop, self.chunk):
            sl = slice(i, min(i + self.chunk, idx.stop))
            t = sample_depths(self.near[sl].to(self.o), self.far[sl].to(self.o), self.samples,
                              jitter=False)
            forward_rays(self.model, src, self.ids.to(self.device), self.o[sl], self.d[sl], t,
                         reference=True)

    def timed(self, reference: bool) -> tuple[float, float]:
        """(encode s, rays s) of one pass: fast (sources encoded once, shared by every frame
        of a path) or reference (sources re-encoded for this frame in fp32)."""
        _sync(self.device)
        t0 = time.perf_counter()
        src = self.encode(grad=reference)
        _sync(self.device)
        enc = time.perf_counter() - t0
        t0 = time.perf_counter()
        (self.reference if reference else self.fast)(src)
        _sync(self.device)
        return enc, time.perf_counter() - t0


def _frame_bench(cfg: BenchConfig, tcfg, scene, device: str, size: tuple[int, int]):
    """The frame's ``_FrameRays`` (random weights: speed does not depend on them) and the
    record's fixed fields."""
    import torch

    from gnfr.model import GNFR
    from gnfr.renderer import cpu_bf16
    from pipeline.render import default_chunk

    torch.manual_seed(0)
    model = GNFR(tcfg.model).to(device).eval()
    W, H = size
    n_src = min(tcfg.eval_views, len(scene.stems) - 1)
    n_rays = cfg.rays or (W * H if device == "cuda" else 4096)
    sources = _sources(scene, tcfg, size, n_src)
    _, o, d = _frame_rays(W, H, n_rays, scene.c2w[n_src].float(), device)
    R = len(o)
    bench = _FrameRays(model=model, sources=sources, o=o, d=d, near=torch.full((R,), 1.0),
                       far=torch.full((R,), 4.5), ids=torch.arange(n_src),
                       samples=cfg.samples or tcfg.samples,
                       chunk=cfg.chunk or default_chunk(device),
                       bf16=cpu_bf16(None, device),  # the render stage's default on this device
                       device=device)
    imgs = sources[0]
    fields = {"rays_timed": R, "samples": bench.samples, "chunk": bench.chunk,
              "cpu_bf16": bench.bf16,
              "sources": f"{n_src} x {imgs.shape[-1]}x{imgs.shape[-2]}"}
    return bench, fields


def bench_render(cfg: BenchConfig, tcfg, scene, device: str, size: tuple[int, int]) -> dict:
    """Seconds per frame at ``size``: fast (cached sources) and reference (re-encoded, fp32,
    unfused), each with peak memory."""
    import torch

    bench, out = _frame_bench(cfg, tcfg, scene, device, size)
    R = out["rays_timed"]
    scale = size[0] * size[1] / R
    repeats = max(cfg.repeats, 1)
    # Both paths are warmed up on a full chunk, then timed alternately ``repeats`` times
    # and the fastest pass of each kept: a single pass in a fixed order let allocator
    # growth and other load on the machine decide which path looked faster.
    warm = slice(0, min(R, bench.chunk))
    best = {"fast": (math.inf, math.inf), "reference": (math.inf, math.inf)}
    peak = {"fast": 0.0, "reference": 0.0}
    with torch.inference_mode():
        src0 = bench.encode()
        bench.fast(src0, warm)
        bench.reference(src0, warm)
        del src0
        for _ in range(repeats):
            for name in ("fast", "reference"):
                with PeakMemory(device) as mem:
                    enc, rays_s = bench.timed(reference=name == "reference")
                peak[name] = max(peak[name], mem.mib)
                if rays_s < best[name][1]:
                    best[name] = (enc, rays_s)
    enc, rays_s = best["fast"]
    out["fast"] = {"s_per_frame": rays_s * scale, "encode_once_s": enc,
                   "ms_per_ray": 1e3 * rays_s / R, "peak_mib": peak["fast"]}
    enc, rays_s = best["reference"]
    out["reference"] = {"s_per_frame": rays_s * scale + enc, "encode_per_frame_s": enc,
                        "ms_per_ray": 1e3 * rays_s / R, "peak_mib": peak["reference"]}
    out["repeats"] = repeats
    out["reference_over_fast"] = out["reference"]["s_per_frame"] / out["fast"]["s_per_frame"]
    return out


def fill_widths(cfg: BenchConfig) -> tuple[int, ...]:
    return (48, 96) if cfg.quick else FILL_WIDTHS


def check_workspace(path: Path) -> tuple:
    """(workspace, checkpoint) of ``--workspace``, or the one-line error of what it lacks."""
    from pipeline import render
    from pipeline.errors import UserError, shell_path
    from pipeline.workspace import Workspace

    ws = Workspace.open(path)
    ws.require("pose")
    ckpt = render.find_checkpoint(ws, None)
    if not ws.depth.is_dir():
        raise UserError(f"{ws.depth} is missing: run `deflare-scene depth "
                        f"{shell_path(ws.root)}` first (the hybrid fill the bench compares "
                        "needs it)")
    return ws, ckpt


@contextlib.contextmanager
def scratch_workspace(path: Path, prefix: str):
    """For a benchmark's ``--workspace``: yields (workspace, checkpoint, scratch), scratch a
    workspace in a temporary folder sharing the workspace's stages (hard links), which the
    benchmark renders into and which is removed after; what the workspace lacks is its
    one-line error (``error: ...``, as the CLI's) as ``SystemExit``. The workspace itself
    is not written to."""
    import tempfile

    from pipeline.errors import UserError
    from workflows.research.eval.workspaces import shared_workspace

    try:
        base, ckpt = check_workspace(path)
    except UserError as e:  # worded as the CLI words a user's error
        raise SystemExit(f"error: {e}") from None
    with tempfile.TemporaryDirectory(prefix=prefix) as tmp:
        yield base, ckpt, shared_workspace(base, Path(tmp) / "ws")


def bench_fill(cfg: BenchConfig, device: str, checked: tuple | None = None) -> dict:
    """Seconds per novel frame of the workspace's interpolate path at each of
    ``fill_widths``: the render stage with ``--fill network`` and with ``--fill hybrid``,
    same frames, same run (``checked``: ``check_workspace``'s answer, if already had). A
    frame's time is the stage's wall time (model load and source
    encoding included, as a user's render pays them) over the frames. After an untimed
    warm-up render of both fills at a small size, every (width, fill) is rendered
    ``repeats`` times, alternating, and the fastest counts: on a shared machine one pass
    in a fixed order measured the load of the moment as much as the path."""
    import tempfile

    from gnfr.paths import PathCamera, path_to_json
    from pipeline import render
    from pipeline.workspace import atomic_write_json
    from pipeline.ws_files import read_cameras
    from workflows.research.eval.workspaces import shared_workspace

    base, ckpt = checked or check_workspace(cfg.workspace)
    n = cfg.fill_frames
    path, _ = render.novel_path(render.RenderConfig(path="interpolate", frames=max(4 * n, 8)),
                                read_cameras(base), device)
    pick = np.linspace(0, len(path) - 1, n).round().astype(int)
    best: dict = {}
    with tempfile.TemporaryDirectory(prefix="deflare-bench-") as tmp:
        ws = shared_workspace(base, Path(tmp) / "ws")

        def frames(width: int) -> tuple[Path, tuple[int, int]]:
            cams = []
            for i in pick:
                s = width / path[i].width
                K = np.asarray(path[i].K, float).copy()
                K[:2] *= s
                cams.append(PathCamera(f"f{i:03d}", K, path[i].c2w, width,
                                       max(8, round(path[i].height * s))))
            pj = Path(tmp) / f"frames_{width}.json"
            atomic_write_json(pj, path_to_json(cams))
            return pj, (width, cams[0].height)

        def timed(pj: Path, fill: str) -> float:
            rc = render.RenderConfig(path=str(pj), fill=fill, device=device,
                                     checkpoint=str(ckpt), chunk=cfg.chunk, samples=cfg.samples)
            _sync(device)
            t0 = time.perf_counter()
            render.run(rc, ws, force=True)
            _sync(device)
            return (time.perf_counter() - t0) / len(pick)

        warm, _ = frames(min(32, *fill_widths(cfg)))
        for fill in ("network", "hybrid"):
            timed(warm, fill)
        jobs = [frames(w) for w in fill_widths(cfg)]
        for _ in range(max(cfg.repeats, 1)):
            for pj, size in jobs:
                for fill in ("network", "hybrid"):
                    best[size, fill] = min(best.get((size, fill), math.inf), timed(pj, fill))
    rows = [{"size": list(size), "fill": fill, "s_per_frame": t}
            for (size, fill), t in best.items()]
    return {"workspace": str(base.root), "checkpoint": str(ckpt), "frames": int(n),
            "repeats": max(cfg.repeats, 1), "rows": rows}


# --------------------------------------------------------------------------- entry point
def measure(isolate: bool, fn, *args) -> dict:
    """``fn(*args)``, in a fresh spawned process when ``isolate`` (same torch threads)."""
    if not isolate:
        return fn(*args)
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor

    import torch

    with ProcessPoolExecutor(1, mp_context=mp.get_context("spawn"),
                             initializer=_child_init,
                             initargs=(torch.get_num_threads(),)) as pool:
        return pool.submit(fn, *args).result()


def _child_init(threads: int) -> None:
    """A measuring process set up as the CLI sets up its own: torch's threads and malloc's
    settings (``gnfr.malloc``)."""
    from gnfr.malloc import keep_freed_memory
    from workflows.threads import apply_thread_policy

    apply_thread_policy(threads)
    keep_freed_memory()


def default_devices() -> tuple[str, ...]:
    import torch

    return ("cpu", "cuda") if torch.cuda.is_available() else ("cpu",)


def run(cfg: BenchConfig) -> dict:
    """Measure every device; write ``cfg.out`` (JSON) and return the record."""

    from gnfr.train import PRESETS
    from pipeline.errors import UserError
    from pipeline.options import resolve_device, validate
    from pipeline.progress import info
    from pipeline.workspace import atomic_write_json

    cfg = effective(validate(cfg))
    if cfg.preset not in PRESETS:
        raise UserError(f"--preset {cfg.preset}: choose one of {', '.join(PRESETS)}")
    if cfg.fill_only and cfg.workspace is None:
        raise UserError("--fill-only times a workspace's novel frames: give --workspace WS")
    devices = cfg.devices or default_devices()
    for d in devices:
        if d not in ("cpu", "cuda"):
            raise UserError(f"--device {d}: must be all, cpu or cuda")
        resolve_device(d)  # cuda without a GPU: the one message
    # the workspace is checked before the long synthetic measurements, and only once
    checked = check_workspace(cfg.workspace) if cfg.workspace is not None else None
    tcfg = PRESETS[cfg.preset]
    # --fill-only times the workspace alone: no synthetic scene to build
    scene = None if cfg.fill_only else synthetic_scene(cfg.views, cfg.train_size)
    record = {"machine": machine(), "settings": {**asdict(cfg), "out": str(cfg.out),
                                                   "devices": list(devices),
                                                   "workspace": cfg.workspace and
                                                   str(cfg.workspace)},
              "preset": {"name": cfg.preset, "rays": tcfg.rays, "samples": tcfg.samples,
                         "depth": tcfg.model.depth, "width": tcfg.model.width,
                         "source_scale": tcfg.source_scale, "n_views": list(tcfg.n_views),
                         "eval_views": tcfg.eval_views},
              "results": {}}
    for dev in devices:
        iso = cfg.isolate and dev == "cpu"
        res = {"train": {}, "render": {}, "isolated_processes": iso}
        for mode in () if cfg.fill_only else TRAIN_MODES:
            if mode == "processes" and (dev != "cpu" or split_processes(tcfg) < 2):
                continue  # the fine-tune shares its steps out on the CPU only
            info(f"bench: {dev} training, {mode} ({cfg.warmup}+{cfg.steps} steps)")
            res["train"][mode] = measure(iso, bench_train, cfg, tcfg, scene, dev, mode)
        for W, H in () if cfg.fill_only else SIZES:
            info(f"bench: {dev} rendering {W}x{H}")
            res["render"][f"{W}x{H}"] = measure(iso, bench_render, cfg, tcfg, scene, dev,
                                                (W, H))
        if cfg.workspace is not None:
            info(f"bench: {dev} novel frames of {cfg.workspace}, GN-FR alone and hybrid")
            res["render_workspace"] = bench_fill(cfg, dev, checked)
        record["results"][dev] = res
    record["memory_method"] = {d: memory_method(d) for d in devices}
    from pipeline.provenance import code_version, command_line

    record["code"], record["command"] = code_version(), command_line()
    atomic_write_json(cfg.out, record)
    return record


def print_table(record: dict) -> None:
    """The record as a table on the terminal: fast beside reference, per device."""
    from rich.console import Console
    from rich.table import Table

    mach = record["machine"]
    preset = record["preset"]
    settings = record["settings"]
    title = (f"deflare-scene bench: {mach['cpu']} ({mach['cores']} cores, "
             f"{mach['torch_threads']} torch threads), torch {mach['torch']}"
             + (f", {mach['cuda']['name']}" if mach.get("cuda") else ""))
    table = Table(
        title=title, caption=f"preset {preset['name']}: depth {preset['depth']} width "
        f"{preset['width']}, {preset['rays']} rays x {preset['samples']} samples per training "
        f"step; render {settings['samples'] or preset['samples']} samples per ray, chunks of "
        f"{settings['chunk'] or '1024 (CUDA) / 256 (CPU)'} rays, "
        f"rays timed per frame: {settings['rays'] or 'whole frame (CUDA) / 4096 (CPU)'}")
    for col in ("device", "measurement", "fast", "reference", "ref / fast", "peak MiB "
                "fast / ref"):
        table.add_column(col, justify="left" if col in ("device", "measurement") else "right")
    for device, results in record["results"].items():
        train = results["train"]
        for mode in ("end_to_end", "cached") if train else ():
            ref = train["reference"]
            table.add_row(device, f"train it/s ({mode.replace('_', '-')})",
                          f"{train[mode]['it_per_s']:.2f}", f"{ref['it_per_s']:.2f}",
                          f"{train[mode]['it_per_s'] / ref['it_per_s']:.2f}x faster",
                          f"{train[mode]['peak_mib']:.0f} / {ref['peak_mib']:.0f}")
        split = train.get("processes")
        if split:
            one = train["end_to_end"]
            table.add_row(device, f"train it/s ({split['processes']} processes of 1 thread, "
                          "the fine-tune's CPU default; ref: one process)",
                          f"{split['it_per_s']:.2f}", f"{one['it_per_s']:.2f}",
                          f"{split['it_per_s'] / one['it_per_s']:.2f}x faster",
                          f"{split['peak_mib']:.0f} (+ helpers) / {one['peak_mib']:.0f}")
        for size, render in results["render"].items():
            table.add_row(device, f"render s/frame {size}",
                          f"{render['fast']['s_per_frame']:.2f}",
                          f"{render['reference']['s_per_frame']:.2f}",
                          f"{render['reference_over_fast']:.2f}x",
                          f"{render['fast']['peak_mib']:.0f} / "
                          f"{render['reference']['peak_mib']:.0f}")
        fill = results.get("render_workspace")
        if fill:
            by = {(tuple(r["size"]), r["fill"]): r["s_per_frame"] for r in fill["rows"]}
            for size in dict.fromkeys(tuple(r["size"]) for r in fill["rows"]):
                net, hyb = by[size, "network"], by[size, "hybrid"]
                table.add_row(device, f"video frame {size[0]}x{size[1]}, s (fast: hybrid "
                              "fill, ref: GN-FR alone)", f"{hyb:.2f}", f"{net:.2f}",
                              f"{net / hyb:.2f}x", "")
    Console().print(table)
