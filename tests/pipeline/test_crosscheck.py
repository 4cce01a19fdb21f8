"""`mask --crosscheck`: the neighbouring photos overrule the FMG's false marks."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from pipeline.crosscheck import Consensus, CrosscheckRule, crosscheck, drop_confirmed


def _disc(shape, cx, cy, r):
    yy, xx = np.mgrid[:shape[0], :shape[1]]
    return (xx - cx) ** 2 + (yy - cy) ** 2 <= r * r


def test_a_region_the_neighbours_see_as_bright_is_dropped_and_a_brighter_one_kept():
    shape = (60, 80)
    scene = np.full(shape, 0.2, np.float32)
    seen, brighter, unjudged = _disc(shape, 20, 20, 6), _disc(shape, 55, 20, 6), \
        _disc(shape, 40, 45, 6)
    view = scene.copy()
    view[brighter] += 0.3          # flare: brighter than what the neighbours see
    support = np.full(shape, 3)
    support[unjudged] = 0          # no neighbour knows this part of the scene
    c = Consensus(view, scene, support)
    out = drop_confirmed(seen | brighter | unjudged, c, CrosscheckRule())
    assert not out[seen].any()
    assert out[brighter].all() and out[unjudged].all()
    # the view a little brighter, within the mask rule's own threshold, is still scene
    c2 = Consensus(scene + 0.015, scene, np.full(shape, 3))
    assert not drop_confirmed(seen, c2, CrosscheckRule()).any()
    # one neighbour is not enough (min_support 2)
    assert drop_confirmed(seen, Consensus(scene, scene, np.ones(shape, int)),
                          CrosscheckRule())[seen].all()
    # a region only partly confirmed (a flare core inside a wide mark) stays whole
    core = _disc(shape, 20, 20, 3)
    c3 = Consensus(np.where(core, 0.6, scene).astype(np.float32), scene, np.full(shape, 3))
    assert drop_confirmed(seen, c3, CrosscheckRule())[seen].all()


def _blob_view(ws, stem, cx, cy):
    """Add a bright blob centred at (cx, cy) to WS/images/<stem>.png."""
    path = ws.images / f"{stem}.png"
    img = cv2.imread(str(path)).astype(np.float32)
    yy, xx = np.mgrid[:img.shape[0], :img.shape[1]]
    glow = np.exp(-((xx - cx) ** 2 + (yy - cy) ** 2) / (2 * 8.0 ** 2))
    cv2.imwrite(str(path), np.clip(img + 140 * glow[..., None], 0, 255).astype(np.uint8))


@pytest.fixture(scope="module")
def temple_ws(tmp_path_factory):
    from tests.fixtures import make_temple_workspace

    return make_temple_workspace(tmp_path_factory.mktemp("cc") / "ws", n_views=6, scale=0.5)


def test_crosscheck_drops_a_false_mark_and_keeps_a_blob_added_to_one_view(temple_ws):
    """A real scene (Middlebury temple, true cameras): in one view a mark on the backdrop,
    which every neighbour sees alike, is dropped; a bright blob added to that view alone
    and marked is kept; other views' empty masks stay empty."""
    ws = temple_ws
    stems = sorted(p.stem for p in ws.images.glob("*.png"))
    _blob_view(ws, stems[2], 45, 170)
    shape = cv2.imread(str(ws.images / f"{stems[2]}.png")).shape[:2]
    false, blob = _disc(shape, 40, 60, 12), _disc(shape, 45, 170, 12)
    masks = {s: np.zeros(shape, bool) for s in stems}
    masks[stems[2]] = false | blob
    out = crosscheck(ws, masks)
    assert set(out) == set(stems)
    assert out[stems[2]][blob].all()
    assert not out[stems[2]][false].any()
    assert not any(out[s].any() for s in stems if s != stems[2])


def test_mask_stage_crosscheck_keeps_the_network_masks_and_writes_the_checked_ones(
        tmp_path, monkeypatch, capsys):
    import torch

    from gnfr.fmg import build_fmg, save_fmg, tiny_config
    from pipeline import mask
    from pipeline.ws_files import read_mask, read_mask_file, write_mask
    from tests.fixtures import make_temple_workspace
    from workflows.cli import main

    ws = make_temple_workspace(tmp_path / "ws", n_views=6, scale=0.5)
    stems = sorted(p.stem for p in ws.images.glob("*.png"))
    _blob_view(ws, stems[2], 45, 170)
    shape = cv2.imread(str(ws.images / f"{stems[2]}.png")).shape[:2]
    false, blob = _disc(shape, 40, 60, 12), _disc(shape, 45, 170, 12)

    def network(model, config, ws, todo, confirm=None):   # the FMG's output, made to order
        for s in todo:
            write_mask(ws, s, (false | blob) if s == stems[2] else np.zeros(shape, bool))

    monkeypatch.setattr(mask, "write_fmg_masks", network)
    torch.manual_seed(0)
    weights = save_fmg(tmp_path / "tiny.safetensors", build_fmg(tiny_config()))
    args = ["mask", str(ws.root), "--weights", str(weights)]
    assert main([*args, "--crosscheck"]) == 0
    fmg_dir = ws.root / mask.FMG_MASKS_DIR
    assert sorted(p.stem for p in fmg_dir.glob("*.png")) == stems
    assert (read_mask_file(fmg_dir / f"{stems[2]}.png") == (false | blob)).all()
    checked = read_mask(ws, stems[2])
    assert checked[blob].all() and not checked[false].any()
    flare = json.loads(ws.flare_json.read_text())
    assert flare["views"][stems[2]]["flare_fraction"] == pytest.approx(checked.mean(), abs=1e-6)
    assert "cross-check dropped" in capsys.readouterr().err
    # without --crosscheck: the network's masks again, and masks_fmg (stale) removed
    assert main(args) == 0
    assert not fmg_dir.exists()
    assert (read_mask(ws, stems[2]) == (false | blob)).all()
    # hand-made masks are kept as given: the two options together are one clear error
    given = tmp_path / "given"
    given.mkdir()
    for s in stems:
        cv2.imwrite(str(given / f"{s}.png"), np.zeros(shape, np.uint8))
    capsys.readouterr()
    assert main(["mask", str(ws.root), "--masks", str(given), "--crosscheck"]) == 2
    err = capsys.readouterr().err.strip()
    assert "--crosscheck" in err and "--masks" in err and len(err.splitlines()) == 1
