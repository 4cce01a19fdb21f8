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


def _three_regions(shape):
    """A flat scene, three discs (left, right, below) and a support of three neighbours
    everywhere except the third disc, which no neighbour knows."""
    scene = np.full(shape, 0.2, np.float32)
    left, right, unjudged = _disc(shape, 20, 20, 6), _disc(shape, 55, 20, 6), \
        _disc(shape, 40, 45, 6)
    support = np.full(shape, 3)
    support[unjudged] = 0
    return scene, left, right, unjudged, support


def test_a_region_the_neighbours_see_as_bright_is_dropped_and_a_brighter_one_kept():
    shape = (60, 80)
    scene, seen, brighter, unjudged, support = _three_regions(shape)
    view = scene.copy()
    view[brighter] += 0.3          # flare: brighter than what the neighbours see
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
    args = ["mask", str(ws.root), "--weights", str(weights), "--no-ghost-lines"]
    assert main([*args, "--crosscheck"]) == 0
    fmg_dir = ws.root / mask.FMG_MASKS_DIR
    assert sorted(p.stem for p in fmg_dir.glob("*.png")) == stems
    assert (read_mask_file(fmg_dir / f"{stems[2]}.png") == (false | blob)).all()
    checked = read_mask(ws, stems[2])
    assert checked[blob].all() and not checked[false].any()
    flare = json.loads(ws.flare_json.read_text())
    assert flare["views"][stems[2]]["flare_fraction"] == pytest.approx(checked.mean(), abs=1e-6)
    assert "other photos dropped" in capsys.readouterr().err
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


def test_add_confirmed_adds_a_candidate_brighter_than_the_neighbours_see_and_nothing_else():
    from pipeline.crosscheck import add_confirmed

    shape = (60, 80)
    scene, seen, ghost, unjudged, support = _three_regions(shape)
    view = scene.copy()
    view[ghost] += 0.1             # a faint ghost: brighter than the scene by the mask rule
    view[unjudged] += 0.3          # no neighbour knows this part: not added, however bright
    out = add_confirmed(ghost | seen | unjudged, Consensus(view, scene, support),
                        CrosscheckRule())
    assert out[ghost].all()
    assert not out[seen].any() and not out[unjudged].any()
    # a sliver of the ghost brighter (under min_brighter 0.3 of it) is not enough
    sliver = ghost & (np.mgrid[:shape[0], :shape[1]][1] >= 59)
    view2 = np.where(sliver, view, scene).astype(np.float32)
    assert 0 < sliver.sum() < 0.3 * ghost.sum()
    assert not add_confirmed(ghost, Consensus(view2, scene, np.full(shape, 3)),
                             CrosscheckRule()).any()
    assert not add_confirmed(np.zeros(shape, bool), Consensus(view, scene, support),
                             CrosscheckRule()).any()


def test_mask_stage_ghost_views_marks_the_candidates_the_other_photos_confirm(
        tmp_path, monkeypatch, capsys):
    """`mask --ghost-lines --ghost-views`: of two ghost-line candidates in one view of a real
    scene, the bright blob only that view shows is marked, the backdrop every neighbour sees
    alike is not; the network's masks and the candidates are kept; a rerun without the
    option removes both folders."""
    import torch

    from gnfr.fmg import build_fmg, save_fmg, tiny_config
    from pipeline import mask
    from pipeline.ws_files import read_mask, read_mask_file, write_mask, write_mask_file
    from tests.fixtures import make_temple_workspace
    from workflows.cli import main

    ws = make_temple_workspace(tmp_path / "ws", n_views=6, scale=0.5)
    stems = sorted(p.stem for p in ws.images.glob("*.png"))
    _blob_view(ws, stems[2], 45, 170)
    shape = cv2.imread(str(ws.images / f"{stems[2]}.png")).shape[:2]
    false, blob, core = _disc(shape, 40, 60, 12), _disc(shape, 45, 170, 12), \
        _disc(shape, 100, 100, 5)

    def network(model, config, ws, todo, confirm=None):   # the FMG's output, made to order
        assert config.ghost_views
        for s in todo:
            cand = (false | blob) if s == stems[2] else np.zeros(shape, bool)
            write_mask_file(ws.root / mask.GHOST_CANDIDATES_DIR / f"{s}.png", cand)
            write_mask(ws, s, core if s == stems[2] else np.zeros(shape, bool))

    monkeypatch.setattr(mask, "write_fmg_masks", network)
    torch.manual_seed(0)
    weights = save_fmg(tmp_path / "tiny.safetensors", build_fmg(tiny_config()))
    args = ["mask", str(ws.root), "--weights", str(weights)]
    assert main([*args, "--ghost-lines", "--ghost-views"]) == 0
    out = read_mask(ws, stems[2])
    assert out[blob].all() and out[core].all() and not out[false].any()
    assert not any(read_mask(ws, s).any() for s in stems if s != stems[2])
    assert (read_mask_file(ws.root / mask.FMG_MASKS_DIR / f"{stems[2]}.png") == core).all()
    kept = read_mask_file(ws.root / mask.GHOST_CANDIDATES_DIR / f"{stems[2]}.png")
    assert (kept == (false | blob)).all()
    assert "confirmed" in capsys.readouterr().err
    monkeypatch.undo()
    assert main([*args, "--no-ghost-lines"]) == 0
    assert not (ws.root / mask.FMG_MASKS_DIR).exists()
    assert not (ws.root / mask.GHOST_CANDIDATES_DIR).exists()
    capsys.readouterr()
    assert main([*args, "--no-ghost-lines", "--ghost-views"]) == 2
    err = capsys.readouterr().err.strip()
    assert "--ghost-lines" in err and len(err.splitlines()) == 1


def test_ghost_views_without_candidates_skip_the_depth_and_keep_the_masks(
        tmp_path, monkeypatch, capsys):
    """With no ghost-line candidate in any view (a capture without a light in frame) the
    views' check has nothing to judge: the masks are the network's, and neither the depth
    nor the warps run (the check's depth is most of the mask stage's time at 1008 px)."""
    import torch

    from gnfr.fmg import build_fmg, save_fmg, tiny_config
    from pipeline import crosscheck, mask
    from pipeline.ws_files import read_mask, write_mask, write_mask_file
    from tests.fixtures import make_temple_workspace
    from workflows.cli import main

    ws = make_temple_workspace(tmp_path / "ws", n_views=4, scale=0.25)
    stems = sorted(p.stem for p in ws.images.glob("*.png"))
    shape = cv2.imread(str(ws.images / f"{stems[0]}.png")).shape[:2]
    core = _disc(shape, 30, 40, 6)

    def network(model, config, ws, todo, confirm=None):   # marks, and no candidate anywhere
        for s in todo:
            write_mask_file(ws.root / mask.GHOST_CANDIDATES_DIR / f"{s}.png",
                            np.zeros(shape, bool))
            write_mask(ws, s, core if s == stems[1] else np.zeros(shape, bool))

    def no_depth(*a, **k):
        raise AssertionError("the views' check ran with nothing to judge")

    monkeypatch.setattr(mask, "write_fmg_masks", network)
    monkeypatch.setattr(crosscheck, "view_consensus", no_depth)
    torch.manual_seed(0)
    weights = save_fmg(tmp_path / "tiny.safetensors", build_fmg(tiny_config()))
    assert main(["mask", str(ws.root), "--weights", str(weights)]) == 0
    assert (read_mask(ws, stems[1]) == core).all()
    assert not any(read_mask(ws, s).any() for s in stems if s != stems[1])
    assert "no ghost-line candidates in any view" in capsys.readouterr().err
    # --crosscheck has marks to judge, so it still asks the views
    with pytest.raises(AssertionError, match="nothing to judge"):
        crosscheck.crosscheck(ws, {s: read_mask(ws, s) for s in stems}, drop=True)


def test_ghost_views_default_on_where_views_can_judge_and_off_for_one_view(tmp_path, capsys):
    """The defaults since the thirty-fifth session: with no option the stage runs the ghost
    lines the other photos judge (two views or more); a single posed view gets the ghost
    lines without the views' judgement and no error, while asking for `--ghost-views` there
    is a one-line error."""
    import torch

    from gnfr.fmg import build_fmg, save_fmg, tiny_config
    from pipeline import mask
    from pipeline.mask import MaskConfig
    from tests.fixtures import make_temple_workspace
    from workflows.cli import main

    torch.manual_seed(0)
    weights = save_fmg(tmp_path / "tiny.safetensors", build_fmg(tiny_config()))
    two = make_temple_workspace(tmp_path / "two", n_views=2, scale=0.25)
    mask.run(MaskConfig(weights=weights), two)
    params = two.stage_record("mask")["params"]
    assert params["ghost_lines"] is True and params["ghost_views"] is True
    assert (two.root / mask.GHOST_CANDIDATES_DIR).is_dir()
    one = make_temple_workspace(tmp_path / "one", n_views=1, scale=0.25)
    mask.run(MaskConfig(weights=weights), one)
    params = one.stage_record("mask")["params"]
    assert params["ghost_lines"] is True and params["ghost_views"] is False
    assert not (one.root / mask.GHOST_CANDIDATES_DIR).exists()
    capsys.readouterr()
    assert main(["mask", str(one.root), "--weights", str(weights), "--ghost-views",
                 "--force"]) == 2
    err = capsys.readouterr().err.strip()
    assert "--ghost-views" in err and "1 posed view" in err and len(err.splitlines()) == 1


def test_ghost_views_with_the_network_writes_a_candidate_file_per_view(tmp_path):
    """The real write path (a tiny FMG): one candidate file per view, each a subset of what
    the ghost-line rule with a chain of one finds, and none of it under the network's cut."""
    import torch

    from gnfr.fmg import build_fmg, save_fmg, tiny_config
    from pipeline import mask
    from pipeline.mask import MaskConfig, ghost_config
    from pipeline.ws_files import read_mask, read_mask_file
    from tests.fixtures import make_temple_workspace

    assert ghost_config(MaskConfig(ghost_lines=True, ghost_views=True)).min_chain == 1
    assert ghost_config(MaskConfig(ghost_lines=True)).min_chain == 2
    ws = make_temple_workspace(tmp_path / "ws", n_views=3, scale=0.5)
    torch.manual_seed(0)
    weights = save_fmg(tmp_path / "tiny.safetensors", build_fmg(tiny_config()))
    mask.run(MaskConfig(weights=weights, ghost_lines=True, ghost_views=True), ws)
    stems = sorted(p.stem for p in ws.images.glob("*.png"))
    for s in stems:
        cand = read_mask_file(ws.root / mask.GHOST_CANDIDATES_DIR / f"{s}.png")
        fmg = read_mask_file(ws.root / mask.FMG_MASKS_DIR / f"{s}.png")
        assert not (cand & fmg).any()
        final = read_mask(ws, s)
        assert (final >= fmg).all() and not (final & ~fmg & ~cand).any()


def test_crosscheck_drops_and_adds_in_one_pass(temple_ws):
    """`--crosscheck` with `--ghost-views` (one depth, one consensus per view): a mark on
    the backdrop is dropped while a candidate over a blob only one view shows is added, and
    a candidate over the backdrop is not; ``drop=False`` keeps the marks as they were."""
    from pipeline.crosscheck import crosscheck

    ws = temple_ws
    stems = sorted(p.stem for p in ws.images.glob("*.png"))
    _blob_view(ws, stems[3], 45, 170)
    shape = cv2.imread(str(ws.images / f"{stems[3]}.png")).shape[:2]
    false, blob, scene = _disc(shape, 40, 60, 12), _disc(shape, 45, 170, 12), \
        _disc(shape, 100, 60, 10)
    masks = {s: np.zeros(shape, bool) for s in stems}
    masks[stems[3]] = false.copy()
    cands = {s: np.zeros(shape, bool) for s in stems}
    cands[stems[3]] = blob | scene
    both = crosscheck(ws, masks, candidates=cands)
    assert both[stems[3]][blob].all()
    assert not both[stems[3]][false].any() and not both[stems[3]][scene].any()
    kept = crosscheck(ws, masks, candidates=cands, drop=False)
    assert kept[stems[3]][false].all() and kept[stems[3]][blob].all()
    assert not any(kept[s].any() for s in stems if s != stems[3])


def test_the_depth_stage_takes_the_checks_plane_sweeps_where_their_inputs_match(
        tmp_path, monkeypatch):
    """The views' check sweeps every view with the depth stage's defaults and keeps the
    sweeps in WS/.sweeps; the depth stage then sweeps again only the views whose own or
    neighbours' masks differ from the ones the check used, gives the depth maps it would
    have computed alone, and removes WS/.sweeps."""
    import shutil

    from pipeline import depth
    from pipeline.workspace import Workspace
    from pipeline.ws_files import read_cameras, read_depth, write_mask
    from tests.fixtures import make_temple_workspace

    ws = make_temple_workspace(tmp_path / "ws", n_views=6, scale=0.25)
    stems = sorted(p.stem for p in ws.images.glob("*.png"))
    shape = cv2.imread(str(ws.images / f"{stems[0]}.png")).shape[:2]
    masks = {s: _disc(shape, 20 + 5 * i, 30, 5) for i, s in enumerate(stems)}
    crosscheck(ws, masks, drop=True)
    assert sorted(p.stem for p in ws.sweeps.glob("*.key")) == stems
    changed = stems[2]
    for s in stems:
        write_mask(ws, s, masks[s] | (_disc(shape, 50, 50, 8) if s == changed else False))
    alone = Workspace(shutil.copytree(ws.root, tmp_path / "alone",
                                      ignore=shutil.ignore_patterns(".sweeps")))
    swept = []
    real = depth.sweep_depths

    def counted(ref, *a, **k):
        swept.append(ref)
        return real(ref, *a, **k)

    monkeypatch.setattr(depth, "sweep_depths", counted)
    main_only = depth.DepthConfig(frames_sgm=None)  # the novel frames' maps sweep every view
    depth.run(main_only, ws)
    near = depth.nearest_views(read_cameras(ws), depth.DepthConfig().neighbours)
    redo = {s for s in stems if s == changed or changed in near[s]}
    assert 0 < len(swept) == len(redo) < len(stems)
    assert ws.stage_record("depth")["sweeps_from_mask_stage"] == len(stems) - len(redo)
    assert not ws.sweeps.exists()
    swept.clear()
    depth.run(main_only, alone)
    assert len(swept) == len(stems)
    for s in stems:
        for a, b in zip(read_depth(ws, s), read_depth(alone, s), strict=True):
            assert np.array_equal(a, b), s
