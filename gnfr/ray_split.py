"""A training step's rays shared by processes on the CPU (``RaySplit``).

GN-FR's rays are independent of each other (the view transformer mixes one point's source
views, the ray transformer one ray's samples), so a step's loss is a sum over its rays: each
process takes a part of the batch's rays, computes that part's loss normalised by the whole
batch's count (``gnfr.train.compute_loss`` with ``whole``) and its gradients, and the sum of
the parts' gradients is the whole batch's gradient, but for the rounding of sums taken in
another order. This process draws the batch, computes part 0, adds the helpers' gradients
and steps the optimizer; the helpers hold the same parameters in shared memory, so each sees
every update without a copy. Nothing of a helper's is state: the checkpoint, the resume, the
RNG and the metrics stay this process's alone, and a run may change its number of processes
between an interruption and its resume.

Each process encodes the step's source views itself: the encoder's forward and backward do
not shrink with the rays (on a ``quick`` step of 128 rays they are some 60 of 155 ms), so
two processes of one thread take a step 1.3x sooner than one, not 2x
(``benchmarks/finetune_split.py``, docs/performance.md).

The helpers are spawned (a fresh interpreter: no copy of this process's threads or locks),
on ``threads`` torch threads each (1 by default); they start with their sources' tensors and
the model (moved to shared memory once, so nothing is copied per step), get each step's whole
batch (a few kB) and the index of its source bank through a pipe, and answer with their
part's sums after writing their gradients into a shared buffer. A helper's exception comes
back as one; a helper that dies without a word raises ``HelperDied``.
"""

from __future__ import annotations

import contextlib
import os
from dataclasses import dataclass

import torch

from gnfr.model import GNFR
from gnfr.renderer import SourceViews
from gnfr.train import Batch, SourceBank, TrainConfig, batch_sources, compute_loss

MIN_RAYS = 16
"""Fewest rays a process takes of a step (``parts``): below it the per-process cost (the
sources' encoding) outweighs the rays' share."""
THREAD_ENV = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
"""Variables a helper starts with at its thread count, so that the libraries that read them
when they load keep to it (torch's own count is set when the helper starts)."""
WAIT_S = 0.5
"""How often a wait for a helper's answer checks that the helper is still alive."""


class HelperDied(RuntimeError):
    """A helper process ended without answering (killed, e.g. for memory)."""


def parts(rays: int, processes: int) -> int:
    """How many processes share a step of ``rays`` rays: ``processes``, fewer where a part
    would hold under ``MIN_RAYS`` rays, at least 1."""
    return max(1, min(processes, rays // MIN_RAYS))


def ray_slices(rays: int, n: int) -> list[slice]:
    """``n`` contiguous slices of ``range(rays)``, their sizes differing by at most one."""
    bounds = [round(i * rays / n) for i in range(n + 1)]
    return [slice(a, b) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]


def part_of(batch: Batch, rows: slice) -> Batch:
    """The rays ``rows`` of ``batch`` (same target and sources)."""
    def cut(x):
        return None if x is None else x[rows]

    return Batch(batch.target, batch.sources, batch.rays_o[rows], batch.rays_d[rows],
                 batch.t[rows], batch.rgb[rows], cut(batch.flare), cut(batch.weight))


def to_wire(batch: Batch) -> tuple:
    """``batch`` as numpy arrays for a pipe (a tensor sent whole would be moved to a
    shared-memory file per step)."""
    def arr(x):
        return None if x is None else x.numpy()

    return (batch.target, arr(batch.sources), arr(batch.rays_o), arr(batch.rays_d),
            arr(batch.t), arr(batch.rgb), arr(batch.flare), arr(batch.weight))


def from_wire(msg: tuple) -> Batch:
    """The ``Batch`` of ``to_wire``."""
    def ten(x):
        return None if x is None else torch.from_numpy(x)

    return Batch(msg[0], *(ten(x) for x in msg[1:]))


def grad_size(model: GNFR) -> int:
    """Values in the gradients a helper sends: every parameter that trains."""
    return sum(p.numel() for p in model.parameters() if p.requires_grad)


def write_grads(model: GNFR, buf: torch.Tensor) -> None:
    """The trained parameters' gradients, flattened in order, into ``buf`` (0 where none)."""
    off = 0
    for p in model.parameters():
        if not p.requires_grad:
            continue
        n = p.numel()
        if p.grad is None:
            buf[off:off + n].zero_()
        else:
            buf[off:off + n].copy_(p.grad.reshape(-1))
        off += n


def add_grads(model: GNFR, buf: torch.Tensor) -> None:
    """Add the flattened gradients ``buf`` (``write_grads``) to the model's."""
    off = 0
    for p in model.parameters():
        if not p.requires_grad:
            continue
        n = p.numel()
        g = buf[off:off + n].view_as(p)
        if p.grad is None:
            p.grad = g.clone()
        else:
            p.grad.add_(g)
        off += n


def part_step(model: GNFR, batch: Batch, index: int, n: int, bank: SourceBank,
              cache: SourceViews | None, cfg: TrainConfig) -> dict:
    """Part ``index`` of ``n`` of one step: its loss's gradients left in the model's
    ``.grad`` (set afresh) and its sums returned (``compute_loss`` with the whole batch)."""
    model.train()
    model.zero_grad(set_to_none=True)
    device = next(model.parameters()).device
    part = part_of(batch, ray_slices(len(batch.rgb), n)[index])
    ctx = torch.no_grad() if cache is not None else contextlib.nullcontext()
    with ctx:
        src, ids = batch_sources(model, part, bank, cache, device)
    loss, info = compute_loss(model, part, src, ids, cfg, whole=batch)
    loss.backward()
    return {"loss": float(loss.detach()), **info}


@dataclass
class _Helper:
    process: object
    conn: object
    grads: torch.Tensor


def _helper_main(model: GNFR, inputs: list, cfg: TrainConfig, index: int, n: int,
                 threads: int, conn, grads: torch.Tensor) -> None:
    """A helper process: for each ``(input index, batch)`` received, part ``index`` of ``n``
    of that step, its gradients into ``grads``, then ``("ok", sums)`` back; ``("error",
    exception)`` on a failure; returns on ``None``. Runs on ``threads`` torch threads."""
    import pickle
    import traceback

    torch.set_num_threads(threads)
    while True:
        try:
            msg = conn.recv()
        except (EOFError, KeyboardInterrupt):  # the trainer has gone, or Ctrl-C: it reports
            return
        if msg is None:
            return
        k, batch = msg[0], from_wire(msg[1])
        try:
            bank, cache = inputs[k]
            sums = part_step(model, batch, index, n, bank, cache, cfg)
            write_grads(model, grads)
        except KeyboardInterrupt:
            return
        except Exception as e:  # noqa: BLE001 (sent to the trainer, which raises it)
            err = RuntimeError(f"a training process failed: {type(e).__name__}: {e}\n"
                               f"{traceback.format_exc()}")
            with contextlib.suppress(Exception):
                pickle.dumps(e)
                err = e
            conn.send(("error", err))
            return
        conn.send(("ok", sums))


@contextlib.contextmanager
def _threads_env(threads: int):
    """``THREAD_ENV`` at ``threads`` in this process's environment while helpers start
    (they inherit it), restored after."""
    old = {k: os.environ.get(k) for k in THREAD_ENV}
    os.environ.update({k: str(threads) for k in THREAD_ENV})
    try:
        yield
    finally:
        for k, v in old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


class RaySplit:
    """``n`` processes per step (this one and ``n - 1`` spawned helpers), each taking a
    contiguous share of the batch's rays (``ray_slices``). A context manager: entering
    starts the helpers (the model's parameters move to shared memory), leaving stops them.
    ``inputs``: every (bank, cache) a step may read (one per scene; the step's own are
    found among them by identity). The helpers run on ``threads`` torch threads each. Pass
    it to ``gnfr.train.train_step`` as ``split``."""

    def __init__(self, model: GNFR, inputs: list[tuple[SourceBank, SourceViews | None]],
                 cfg: TrainConfig, n: int, threads: int = 1):
        if n < 2:
            raise ValueError(f"RaySplit needs 2 or more processes, not {n}")
        self.model, self.inputs, self.cfg, self.n = model, list(inputs), cfg, n
        self.threads = threads
        self.helpers: list[_Helper] = []

    def __enter__(self) -> RaySplit:
        import torch.multiprocessing as mp

        if next(self.model.parameters()).device.type != "cpu":
            raise ValueError("RaySplit shares CPU memory: the model must be on the CPU")
        self.model.share_memory()
        ctx = mp.get_context("spawn")
        try:
            with _threads_env(self.threads):  # the helpers start here and inherit it
                for i in range(1, self.n):
                    ours, theirs = ctx.Pipe()
                    grads = torch.zeros(grad_size(self.model)).share_memory_()
                    p = ctx.Process(target=_helper_main, daemon=True,
                                    args=(self.model, self.inputs, self.cfg, i, self.n,
                                          self.threads, theirs, grads))
                    p.start()
                    theirs.close()
                    self.helpers.append(_Helper(p, ours, grads))
        except BaseException:
            self.close()
            raise
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Stop the helpers (asked to end; terminated if they do not within a few
        seconds)."""
        for h in self.helpers:
            with contextlib.suppress(OSError, ValueError):
                h.conn.send(None)
        for h in self.helpers:
            h.process.join(timeout=5)
            if h.process.is_alive():
                h.process.terminate()
                h.process.join()
            h.conn.close()
        self.helpers = []

    def send(self, batch: Batch, bank: SourceBank, cache: SourceViews | None) -> Batch:
        """Hand the helpers their parts of ``batch`` (read from ``bank`` / ``cache``) and
        return this process's part (the first)."""
        k = next((i for i, (b, c) in enumerate(self.inputs) if b is bank and c is cache),
                 None)
        if k is None:
            raise ValueError("the step's source bank is not one the helpers were given")
        wire = (k, to_wire(batch))
        for h in self.helpers:
            try:
                h.conn.send(wire)
            except (OSError, ValueError) as e:
                raise self._died(h) from e
        return part_of(batch, ray_slices(len(batch.rgb), self.n)[0])

    def gather(self, model: GNFR) -> list[dict]:
        """Wait for every helper's part, add its gradients to ``model``'s and return its
        sums (``compute_loss``'s, with ``loss``)."""
        out = []
        for h in self.helpers:
            while not h.conn.poll(WAIT_S):
                if not h.process.is_alive() and not h.conn.poll():
                    raise self._died(h)
            try:
                kind, value = h.conn.recv()
            except EOFError as e:
                raise self._died(h) from e
            if kind == "error":
                raise value
            add_grads(model, h.grads)
            out.append(value)
        return out

    @staticmethod
    def _died(h: _Helper) -> HelperDied:
        h.process.join(timeout=1)
        code = h.process.exitcode
        return HelperDied(f"a training process stopped without answering (exit code {code}"
                          f"{', killed: out of memory?' if code is not None and code < 0 else ''})")
