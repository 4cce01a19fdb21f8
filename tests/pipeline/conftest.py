"""Fixtures of tests/pipeline: `rws` (the posed temple workspace with one flare square, per
module), `hws` (the textured-plane workspace with depth, per module), `counters` (the renderer's
calls and rays counted)."""

from __future__ import annotations

import pytest

from tests.pipeline.render_ws import (
    HYBRID_BOX,
    HYBRID_FLARED,
    Counter,
    add_masks_views_model,
    make_render_ws,
)


@pytest.fixture(scope="module")
def rws(tmp_path_factory):
    return make_render_ws(tmp_path_factory.mktemp("render") / "ws")


@pytest.fixture
def counters(monkeypatch):
    import gnfr.renderer as R

    rays, enc = Counter(R.render_rays), Counter(R.SourceViews.encode)
    monkeypatch.setattr(R, "render_rays", rays)
    monkeypatch.setattr(R.SourceViews, "encode", enc)
    return rays, enc


@pytest.fixture(scope="module")
def hws(tmp_path_factory):
    """A textured-plane workspace (exact cameras) with a fake flare square in one view,
    views.json, a tiny random model, and WS/depth from the depth stage (without the novel
    frames' maps: the tests of the render's options were written against WS/depth)."""
    from pipeline.depth import DepthConfig
    from pipeline.depth import run as depth_run
    from tests.fixtures import make_plane_workspace

    ws = make_plane_workspace(tmp_path_factory.mktemp("hybrid") / "ws")
    add_masks_views_model(ws, HYBRID_FLARED, HYBRID_BOX, 0)
    depth_run(DepthConfig(neighbours=3, frames_sgm=None), ws)
    return ws

