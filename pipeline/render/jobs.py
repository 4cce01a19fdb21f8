"""The typed frame job (one image to render, optional full-res payload) and its prepared rays."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from pipeline.cameras import Frame

if TYPE_CHECKING:  # gnfr is imported lazily (importing it sets OMP_WAIT_POLICY)
    from gnfr.paths import PathCamera


@dataclass(frozen=True)
class FullRes:
    """What a ``--full-res`` job blends into (see pipeline/render/full_res.py)."""

    photo: Path
    """The original photo, or ``WS/linear/<stem>.tiff`` for a camera raw photo."""
    linear: bool
    """True for a raw photo: the render is blended in linear camera RGB."""
    exif: Path | None = None
    """A JPEG whose Exif segment the written JPEG keeps (orientation reset)."""


@dataclass(frozen=True)
class SourceSet:
    """Another frame's sources, rendered at a job's camera and cross-faded into its frame
    (``RenderConfig.source_fade``)."""

    sources: tuple[str, ...]
    """GN-FR's sources, as that frame chose them."""
    fill_first: tuple[str, ...]
    """The photos that frame's fill took first (its sources nearest its camera)."""
    weight: float
    """This set's share of the job's frame."""


@dataclass
class FrameJob:
    """One image to render: where it goes, which camera, which sources, depth range.

    ``camera`` is a :class:`pipeline.cameras.Frame` for an input view (de-flared at the
    size of WS/decoded, or at the original photo's size when ``full_res`` is set) and a
    ``gnfr.paths.PathCamera`` for a novel frame."""

    out: Path
    sources: list[str]
    near: float
    far: float
    camera: Frame | PathCamera
    full_res: FullRes | None = None
    fill_first: tuple[str, ...] | None = None
    """The photos the hybrid fill takes first, whatever their distance (another frame's: in a
    cross-fade, or held, ``RenderConfig.source_hold``); None: the sources nearest the
    camera."""
    fades: tuple[SourceSet, ...] = ()
    """Other frames' sources cross-faded into this frame (``RenderConfig.source_fade``); the
    job's own sources take the weight they leave."""
    exposure: tuple[float, ...] | None = None
    """The frame's gain to the model's common exposure (``RenderConfig.path_exposure``):
    GN-FR's colours are taken back by its inverse and the photos of the fill brought to it
    by ``photo_gains``; None: the median of the sources' gains, the fill's photos matched to
    their own median (``engine.exposure_back``)."""
    photo_gains: dict | None = None
    """{stem: gain to the common exposure} of the photos (the model's, shared by the
    path's jobs), with ``exposure``."""
    same_spot: float = 0.0
    """Photos within this distance of the fill's nearest photo stand at its spot
    (``RenderConfig.key_spot`` times the median distance between the cameras; 0: none):
    the key blend reaches past them and leans to them too."""

    @property
    def all_sources(self) -> list[str]:
        """Every view the job renders with, its fades' included, in first-seen order."""
        seen = dict.fromkeys(self.sources)
        for f in self.fades:
            seen.update(dict.fromkeys(f.sources))
        return list(seen)

    def fill_order(self, centre: np.ndarray, centre_of: Callable[[str], np.ndarray],
                   among) -> list[str]:
        """The job's sources that are in ``among``, nearest ``centre`` (its camera's) first
        (``centre_of``: a stem's camera centre), its ``fill_first`` before the rest when set:
        the order in which the hybrid fill takes its photos."""
        c = np.asarray(centre, float)
        near = sorted((s for s in self.sources if s in among),
                      key=lambda s: float(np.linalg.norm(np.asarray(centre_of(s)) - c)))
        if self.fill_first is None:
            return near
        return ([s for s in near if s in self.fill_first]
                + [s for s in near if s not in self.fill_first])

    def photo_stems(self, k: int) -> set[str]:
        """The photos the job's fill can warp: the first ``k`` of its sources and of each
        fade's, and every ``fill_first``."""
        stems = set(self.sources[:k]) | set(self.fill_first or ())
        for f in self.fades:
            stems |= set(f.sources[:k]) | set(f.fill_first)
        return stems

    @property
    def is_input(self) -> bool:
        """An input view (its photo blended with the render), not a novel frame."""
        return isinstance(self.camera, Frame)

    @property
    def exif(self) -> Path | None:
        """The JPEG whose Exif the written frame keeps (full-resolution JPEGs only)."""
        return self.full_res.exif if self.full_res is not None else None


class Prepared(NamedTuple):
    """A job ready to render: the rays GN-FR renders and how their colours become the image."""

    rays_o: Any
    """torch.Tensor [R, 3]: ray origins (R may be 0: nothing to render)."""
    rays_d: Any
    """torch.Tensor [R, 3]: ray directions."""
    compose: Callable[[np.ndarray], np.ndarray]
    """rgb [R, 3] float -> the frame [H, W, 3] (uint8, or uint16 for a 16-bit original)."""
    guided: tuple[Any, Any] | None = None
    """(depth [R], known [R] bool) tensors for depth-guided sampling, or None."""
    with_depth: bool = False
    """``compose`` takes (rgb [R, 3], depth [R]): GN-FR's z-depth of each ray too."""
