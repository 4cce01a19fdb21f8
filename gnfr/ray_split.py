"""A training step's rays shared by processes on the CPU (``RaySplit``).

GN-FR's rays are independent of each other (the view transformer mixes one point's source
views, the ray transformer one ray's samples), so a step's loss is a sum over its rays: each
process takes a part of the batch's rays and computes that part's loss normalised by the
whole batch's count (``gnfr.train.compute_loss`` with ``whole``), and the parts' gradients
add up to the whole batch's gradient, but for the rounding of sums taken in another order.

This process draws the batch, sends the helpers their rows, computes its own part, adds the
helpers' gradients and steps the optimizer; the helpers hold the same parameters in shared
memory, so each sees every update without a copy. End to end (the encoder trained), the
step's source views are shared out too: each process encodes a share of them
(``view_groups``) into a shared buffer, takes its rays' loss on every view's features as a
leaf, writes that leaf's gradient back, and runs the encoder's backward for its own views on
every process's gradient for them, summed. So the encoder's forward and backward, which do
not shrink with the rays, are shared as well as the rays, at the cost of two exchanges
through the pipes per step.

Nothing of a helper's is state: the checkpoint, the resume, the RNG and the metrics stay
this process's alone, and a run may change its number of processes between an interruption
and its resume. With dropout each process draws its own masks. The processes encode a
share of the views each where one process encodes them together, and sum in another order:
a run's weights differ from a one-process run's by rounding, which training compounds as
another thread count does.

The helpers are spawned (a fresh interpreter: no copy of this process's threads or locks),
on ``threads`` torch threads each (1 by default); they start with their sources' tensors and
the model (moved to shared memory once, so nothing is copied per step), get each step's
whole batch (a few kB), its bank's index and their rows through a pipe, and answer with
their part's sums after writing their gradients into shared buffers. A helper's exception
comes back as one; a helper that dies without a word raises ``HelperDied``. Measured by
``benchmarks/finetune_split.py`` (docs/performance.md).
"""

from __future__ import annotations

import contextlib
import math
import os
from dataclasses import dataclass

import torch

from gnfr.model import GNFR
from gnfr.renderer import SourceViews
from gnfr.train import Batch, SourceBank, TrainConfig, add_parts, batch_sources, compute_loss

MIN_RAYS = 16
"""Fewest rays a helper takes of a step (``parts``): below it the per-process cost (the
sources' encoding) outweighs the rays' share."""
THREAD_ENV = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
"""Variables a helper starts with at its thread count, so that the libraries that read them
when they load keep to it (torch's own count is set when the helper starts)."""
WAIT_S = 0.5
"""How often a wait for a helper's answer checks that the helper is still alive."""


SHM = "/dev/shm"
"""Where torch's shared tensors live on Linux (a tmpfs: Docker gives containers 64 MB of it
unless told ``--shm-size``)."""
SHM_MARGIN = 1.25
"""The free shared memory a split asks for, over what it counts it will put there."""


class HelperDied(RuntimeError):
    """A helper process ended without answering (killed, e.g. for memory)."""


class NoSharedMemory(RuntimeError):
    """The processes would need more shared memory than the machine has free."""


def free_shared_memory() -> int | None:
    """Bytes free in ``SHM`` (None where there is no such folder: torch then shares memory
    another way, unchecked)."""
    try:
        st = os.statvfs(SHM)
    except OSError:
        return None
    return st.f_bavail * st.f_frsize


def tensor_bytes(*objs) -> int:
    """Bytes of the distinct tensor storages held by ``objs`` (tensors, dataclasses of them,
    lists and tuples of either, modules' parameters)."""
    seen: dict[int, int] = {}

    def visit(x) -> None:
        if isinstance(x, torch.Tensor):
            st = x.untyped_storage()
            seen[st.data_ptr()] = st.nbytes()
        elif isinstance(x, torch.nn.Module):
            for t in x.parameters():
                visit(t)
        elif isinstance(x, (list, tuple)):
            for t in x:
                visit(t)
        elif hasattr(x, "__dataclass_fields__"):
            for name in x.__dataclass_fields__:
                visit(getattr(x, name))

    for o in objs:
        visit(o)
    return sum(seen.values())


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


def _grad_rows(model: GNFR):
    """(parameter, its slice of a flat gradient buffer) for every parameter that trains, in
    order (``grad_size`` values in all)."""
    off = 0
    for p in model.parameters():
        if p.requires_grad:
            yield p, slice(off, off + p.numel())
            off += p.numel()


def write_grads(model: GNFR, buf: torch.Tensor) -> None:
    """The trained parameters' gradients, flattened in order, into ``buf`` (0 where none)."""
    for p, rows in _grad_rows(model):
        if p.grad is None:
            buf[rows].zero_()
        else:
            buf[rows].copy_(p.grad.reshape(-1))


def add_grads(model: GNFR, buf: torch.Tensor) -> None:
    """Add the flattened gradients ``buf`` (``write_grads``) to the model's."""
    for p, rows in _grad_rows(model):
        g = buf[rows].view_as(p)
        if p.grad is None:
            p.grad = g.clone()
        else:
            p.grad.add_(g)


def view_groups(views: int, n: int) -> list[slice]:
    """``n`` contiguous slices of ``range(views)`` (the step's source views each process
    encodes), the first (this process's, which also steps the optimizer) the smallest."""
    bounds = [i * views // n for i in range(n + 1)]
    return [slice(a, b) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]


@dataclass
class Shared:
    """The buffers the processes exchange a step's feature maps through (shared memory)."""

    feats: torch.Tensor
    """[max views * C * h * w] every source view's features, each process writing its
    ``view_groups`` share."""
    feat_grads: list[torch.Tensor]
    """Per process, the same size: its part's gradient with respect to every view's
    features."""
    shapes: list[tuple[int, int, int]]
    """(C, h, w) of each input's feature maps."""

    def features(self, k: int, views: int) -> torch.Tensor:
        """[views, C, h, w] of input ``k``'s step: the features buffer's head."""
        return self._head(self.feats, k, views)

    def grads(self, p: int, k: int, views: int) -> torch.Tensor:
        """[views, C, h, w]: process ``p``'s feature gradients of input ``k``'s step."""
        return self._head(self.feat_grads[p], k, views)

    def _head(self, buf: torch.Tensor, k: int, views: int) -> torch.Tensor:
        shape = self.shapes[k]
        return buf[:views * math.prod(shape)].view(views, *shape)


def part_step(model: GNFR, batch: Batch, rows: slice, k: int, bank: SourceBank,
              cache: SourceViews | None, cfg: TrainConfig, me: int = 0, n: int = 1,
              shared: Shared | None = None, sync=None) -> dict:
    """Process ``me`` of ``n``'s part of one step, its gradients left in the model's
    ``.grad`` (set afresh); returns its sums (``compute_loss`` with the whole batch, and
    ``loss``). With the cached features (``cache``) the rays ``rows`` alone. End to end:
    the process encodes its ``view_groups`` share of the step's sources into ``shared``,
    ``sync("feats")`` waits until every process has; its rays' loss is taken on every
    view's features as a leaf, whose gradient goes into ``shared``; after ``sync("grads")``
    its views' encoder backward runs on every process's gradient for them, summed. One
    process (``n`` = 1, no ``shared``) is the whole step."""
    model.train()
    model.zero_grad(set_to_none=True)
    device = next(model.parameters()).device
    part = part_of(batch, rows)
    if cache is not None:
        with torch.no_grad():
            src, ids = batch_sources(model, part, bank, cache, device)
        loss, info = compute_loss(model, part, src, ids, cfg, whole=batch)
        loss.backward()
        return {"loss": float(loss.detach()), **info}
    ids = batch.sources
    group = view_groups(len(ids), n)[me]
    own = (bank.encode(model, device, ids[group], grad=True).feats
           if group.stop > group.start else None)
    if shared is None:
        feats = own
    else:
        feats = shared.features(k, len(ids))
        if own is not None:
            feats[group].copy_(own.detach())
        sync("feats")
    leaf = feats.detach().clone().requires_grad_()
    src = bank.views(ids, leaf, device)
    loss, info = compute_loss(model, part, src, torch.arange(len(ids), device=device), cfg,
                              whole=batch)
    loss.backward()
    grad = leaf.grad if leaf.grad is not None else torch.zeros_like(leaf)
    if shared is not None:
        shared.grads(me, k, len(ids)).copy_(grad)
        sync("grads")
        grad = shared.grads(0, k, len(ids)).clone()
        for q in range(1, n):
            grad += shared.grads(q, k, len(ids))
    if own is not None:
        own.backward(grad[group])
    return {"loss": float(loss.detach()), **info}


class _Stop(Exception):
    """The trainer asked a helper to end (or went away)."""


@dataclass
class _Helper:
    process: object
    conn: object
    grads: torch.Tensor


def _helper_main(model: GNFR, inputs: list, cfg: TrainConfig, me: int, n: int,
                 threads: int, conn, grads: torch.Tensor, shared: Shared) -> None:
    """Helper ``me`` of ``n``: for each ``(input, batch, rows)`` received, its part of that
    step (``part_step``, its syncs answered through ``conn``), its parameters' gradients
    into ``grads``, then ``("ok", sums)`` back; ``("error", exception)`` on a failure;
    returns on ``None``. Runs on ``threads`` torch threads."""
    import pickle
    import traceback

    from gnfr.malloc import keep_freed_memory

    torch.set_num_threads(threads)
    keep_freed_memory()

    def recv():
        try:
            msg = conn.recv()
        except EOFError:  # the trainer has gone
            raise _Stop from None
        if msg is None:
            raise _Stop
        return msg

    def sync(kind: str) -> None:
        conn.send((kind,))
        if recv() != ("go",):
            raise RuntimeError("a training process lost step with the trainer")

    while True:
        try:
            k, wire, a, b = recv()
            bank, cache = inputs[k]
            sums = part_step(model, from_wire(wire), slice(a, b), k, bank, cache, cfg, me, n,
                             shared, sync)
            write_grads(model, grads)
        except (_Stop, KeyboardInterrupt):  # Ctrl-C reaches every process: the trainer reports
            return
        except Exception as e:  # noqa: BLE001 (sent to the trainer, which raises it)
            err = RuntimeError(f"a training process failed: {type(e).__name__}: {e}\n"
                               f"{traceback.format_exc()}")
            with contextlib.suppress(Exception):
                pickle.dumps(e)
                err = e
            with contextlib.suppress(OSError, ValueError):
                conn.send(("error", err))
            return
        conn.send(("ok", sums))


@contextlib.contextmanager
def threads_env(threads: int):
    """``THREAD_ENV`` at ``threads`` in this process's environment while child processes
    start (they inherit it; the render's frame workers too), restored after."""
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
    """``n`` processes per step (this one and ``n - 1`` spawned helpers), each taking an
    even contiguous share of the batch's rays (``ray_slices``) and, end to end, of its
    source views' encoding (``view_groups``). A context manager: entering starts the
    helpers (the model's parameters move to shared memory), leaving stops them.
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
        self.shared: Shared | None = None

    def _shared(self) -> Shared:
        """Buffers for the largest step: ``cfg.n_views``' most views of the largest
        feature maps (each input's shape from encoding one of its views)."""
        device = next(self.model.parameters()).device
        shapes = []
        with torch.no_grad():
            for bank, _ in self.inputs:
                f = bank.encode(self.model, device, torch.tensor([0])).feats
                shapes.append(tuple(int(x) for x in f.shape[1:]))
        size = max(self.cfg.n_views) * max(math.prod(s) for s in shapes)
        return Shared(torch.zeros(size), [torch.zeros(size) for _ in range(self.n)], shapes)

    def _check_room(self) -> None:
        """``NoSharedMemory`` unless ``SHM`` has room (with ``SHM_MARGIN``) for what the
        split puts there: the parameters, every input's tensors, the exchange buffers and
        the helpers' gradients."""
        free = free_shared_memory()
        if free is None:
            return
        need = tensor_bytes(self.model, self.inputs, self.shared)
        need += (self.n - 1) * 4 * grad_size(self.model)
        if need * SHM_MARGIN > free:
            raise NoSharedMemory(f"the {self.n} processes need {need / 2**20:.0f} MB of shared "
                                 f"memory and {SHM} has {free / 2**20:.0f} MB free")

    def __enter__(self) -> RaySplit:
        import torch.multiprocessing as mp

        if next(self.model.parameters()).device.type != "cpu":
            raise ValueError("RaySplit shares CPU memory: the model must be on the CPU")
        self.shared = self._shared()
        self._check_room()
        try:
            self.model.share_memory()
            for t in (self.shared.feats, *self.shared.feat_grads):
                t.share_memory_()
        except RuntimeError as e:  # e.g. "unable to write to file </torch_...>"
            raise NoSharedMemory(f"shared memory for the {self.n} processes: {e}") from None
        ctx = mp.get_context("spawn")
        try:
            with threads_env(self.threads):  # the helpers start here and inherit it
                for i in range(1, self.n):
                    ours, theirs = ctx.Pipe()
                    grads = torch.zeros(grad_size(self.model)).share_memory_()
                    p = ctx.Process(target=_helper_main, daemon=True,
                                    args=(self.model, self.inputs, self.cfg, i, self.n,
                                          self.threads, theirs, grads, self.shared))
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

    def step(self, model: GNFR, batch: Batch, bank: SourceBank,
             cache: SourceViews | None) -> dict:
        """One step's gradients of ``batch`` (read from ``bank`` / ``cache``) in ``model``'s
        ``.grad``, its parts computed by every process; returns the step's loss, psnr, mse
        and all_flared (``add_parts``)."""
        if model is not self.model:
            raise ValueError("RaySplit.step: not the model the helpers share")
        k = next((i for i, (b, c) in enumerate(self.inputs) if b is bank and c is cache),
                 None)
        if k is None:
            raise ValueError("the step's source bank is not one the helpers were given")
        rows = ray_slices(len(batch.rgb), self.n)
        wire = to_wire(batch)
        for h, r in zip(self.helpers, rows[1:], strict=True):
            try:
                h.conn.send((k, wire, r.start, r.stop))
            except (OSError, ValueError) as e:
                raise self._died(h) from e
        sums = part_step(model, batch, rows[0], k, bank, cache, self.cfg, 0, self.n,
                         self.shared, self._sync)
        parts = [sums]
        for h in self.helpers:
            parts.append(self._expect(h, "ok")[1])
            add_grads(model, h.grads)
        return add_parts(parts)

    def _sync(self, kind: str) -> None:
        """This process's side of a sync: every helper's ``kind`` message, then go."""
        for h in self.helpers:
            self._expect(h, kind)
        for h in self.helpers:
            try:
                h.conn.send(("go",))
            except (OSError, ValueError) as e:
                raise self._died(h) from e

    def _expect(self, h: _Helper, kind: str) -> tuple:
        """The helper's next message, of ``kind``; its error raised; ``HelperDied`` when it
        ends without one."""
        while not h.conn.poll(WAIT_S):
            if not h.process.is_alive() and not h.conn.poll():
                raise self._died(h)
        try:
            msg = h.conn.recv()
        except EOFError as e:
            raise self._died(h) from e
        if msg[0] == "error":
            raise msg[1]
        if msg[0] != kind:
            raise RuntimeError(f"a training process answered {msg[0]!r}, not {kind!r}")
        return msg

    @staticmethod
    def _died(h: _Helper) -> HelperDied:
        h.process.join(timeout=1)
        code = h.process.exitcode
        return HelperDied(f"a training process stopped without answering (exit code {code}"
                          f"{', killed: out of memory?' if code is not None and code < 0 else ''})")
