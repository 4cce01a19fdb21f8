"""Test workspaces built without pycolmap, from ground-truth cameras.

``make_temple_workspace`` turns Middlebury templeSparseRing (ground-truth K, R, t in
``templeSR_par.txt``) into a posed workspace (``images/``, ``decoded/``, ``cameras.json``,
manifest with decode and pose complete) through ``workflows.pretrain_scenes`` (the same code
that makes pretraining workspaces), so model, mask and render tests need not run SfM.
"""

from __future__ import annotations

import numpy as np

from pipeline.workspace import Workspace
from tests.conftest import shared
from workflows.pretrain_scenes import BOXES, middlebury, write_workspace
from workflows.pretrain_scenes import read_par as read_temple_par

__all__ = ["make_temple_workspace", "read_temple_par"]


def make_temple_workspace(root, n_views: int = 8, scale: float = 0.5) -> Workspace:
    """A posed workspace of the first ``n_views`` temple views (640x480) resized by ``scale``."""
    src = shared("scenes", "temple")
    views = middlebury(src, "temple")[:n_views]
    write_workspace(root, src, views, max_size=round(640 * scale),
                    box=np.array(BOXES["temple"]))
    return Workspace(root)
