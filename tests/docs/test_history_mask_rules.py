"""docs/history/fmg.md, the FMG card and docs/options.md: the mask stage's rules and options
(flare rays, streak lines, ghost lines, padded runs, the target rule, light cores, the glow
probe) are the result files' and judges'.

Split from tests/docs/test_history_masks.py in the ninety-sixth session.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tests.conftest import load_benchmark
from tests.docs.fmg_numbers import clean_triples, photo_verdict
from tests.docs.numbers import (
    REPO,
    RESULTS,
    page_text,
    result,
    spaced,
)


def card_and_goals_quote(quotes) -> None:
    """Each of ``quotes`` is on the FMG card and on docs/goals.md (line breaks as spaces)."""
    for page in (REPO / "gnfr" / "weights" / "fmg.md", REPO / "docs" / "goals.md"):
        text = " ".join(page.read_text().split())
        assert all(q in text for q in quotes), (page, quotes)


def quote_streaks_and_sceaux(kinds: dict, base: str, cand: str, clean: dict, setting: str,
                             tail: str = "") -> None:
    """The card and the goals page quote a candidate's streak IoU against its base's
    (``kinds``: kind -> arm -> IoU) and what it marks of sceaux_castle's clean photos against
    the stage's rule (``clean``: (scene, setting) -> share marked), followed by ``tail``."""
    card_and_goals_quote((
        f"streaks {kinds['streaks'][base]:.3f} to {kinds['streaks'][cand]:.3f}",
        f"{100 * clean['sceaux_ws', 'ghost_views']:.3f} % to "
        f"{100 * clean['sceaux_ws', setting]:.3f} %{tail}"))


def failed_streaks_judgement(names: list[str], base: str, cand: str, saved_name: str,
                             label: str, flat: str) -> dict:
    """A change aimed at streaks judged again from its one-kind files (``mask_kind_scenes.py
    judge --target streaks``): equal to its saved judgement, a fail, and the page's row
    ``| 1. LABEL, streaks | base | candidate | +0.03 |`` its numbers."""
    mk = load_benchmark("mask_kind_scenes")
    files = [result(n)["rows"] for n in names]
    judged = mk.judge(files, base, cand, target="streaks")
    saved = result(saved_name)
    assert judged["passes"] is False is saved["passes"]
    assert judged["mean"] == pytest.approx(saved["mean"], abs=1e-12)
    k = judged["kinds"]["streaks"]
    assert f"| 1. {label}, streaks | {k[base]:.3f} | {k[cand]:.3f} | +0.03 |" in flat
    return judged


def test_fmg_opposite_rays_table_is_its_files():
    """docs/history/fmg.md's table for the lone-streak rule (sixty-first session) is the
    committed files' numbers: the judge's per-kind means (its verdict a fail, its base M's
    pooled mean), the every-kind scenes and the mask stage on the clean photos."""
    flat = page_text("docs/history/fmg.md")
    base, cand = "fmg.safetensors@1+rays3,0", "fmg.safetensors@1+rays3,8"
    judged = failed_streaks_judgement([f"mask_dev_kinds_opp_s{b}.json" for b in (31, 32, 33)],
                                      base, cand, "mask_kinds_judge_opp8_s61.json",
                                      "one-kind scenes", flat)
    k = judged["kinds"]
    others = ("starburst", "ghosts", "glare", "scatter")
    row = (f"| 1. ... starburst / ghosts / glare / scatter | "
           f"{' / '.join(f'{k[n][base]:.3f}' for n in others)} | "
           f"{' / '.join(f'{k[n][cand]:.3f}' for n in others)} | none -0.01 |")
    assert row in flat, row
    assert (f"| 1. ... mean over kinds | {judged['mean'][base]:.4f} | "
            f"{judged['mean'][cand]:.4f} | not lower |") in flat
    assert f"{judged['mean'][base]:.4f}" == "0.3258"
    rows = result("mask_dev_scenes_opp.json")["rows"]
    by = {(r["scene"], tuple(r["ray_rule"])): r for r in rows if r["rays"]}
    scenes = ("sceaux_synth", "et_synth", "lund_synth")
    for rule in ((3, 0.0), (3, 8.0)):
        iou = " / ".join(f"{by[s, rule]['flare_iou']:.3f}" for s in scenes)
        out = " / ".join(f"{100 * by[s, rule]['marked_outside']:.2f}" for s in scenes)
        assert iou in flat and f"{out} %" in flat, (iou, out)
    views = result("mask_views_clean_dev_opp.json")["rows"]
    vb = {(r["scene"], r["setting"]): r["marked"] for r in views}
    for setting in ("ghost_views", "ghost_views_opp"):
        cells = " / ".join(f"{100 * vb[s, setting]:.3f}" for s in ("lund_ws", "sceaux_ws", "et_ws"))
        assert f"{cells} %" in flat, cells
    # the card and the goals page quote the streaks and sceaux_castle's clean photos
    quote_streaks_and_sceaux(k, base, cand, vb, "ghost_views_opp", " marked")


def test_ghost_views_verdicts_are_the_judge_of_the_committed_scores():
    """G3's two verdicts in docs/history/fmg.md ("Thirty-fourth session") are
    mask_kind_scenes.py's judgements of the committed scores (the first, kind-blind rule
    fails on the mean; the second, aimed at ghosts, passes), and the clean-photo parts are
    the committed files' numbers."""
    mk = load_benchmark("mask_kind_scenes")
    hist = page_text("docs/history/fmg.md")
    base, cand = "fmg.safetensors@1", "fmg.safetensors@1+ghosts+views"
    for seeds, target, saved_name in (((40, 41, 42), None, "mask_kinds_judge_G3.json"),
                                      ((43, 44, 45), "ghosts", "mask_kinds_judge_G3_ghosts.json")):
        files = [result(f"mask_views_kinds_G3_s{s}.json")["rows"]
                 for s in seeds]
        res = mk.judge(files, base, cand, target=target)
        saved = result(saved_name)
        assert res["passes"] is saved["passes"] is (target is not None)
        g = res["kinds"]["ghosts"]
        assert f"ghosts {g[base]:.3f} to {g[cand]:.3f}" in hist or \
            f"ghosts {g[base]:.3f} | ghosts {g[cand]:.3f}" in hist or \
            f"| ghosts {g[base]:.3f}, mean {res['mean'][base]:.4f} | ghosts {g[cand]:.3f}" in hist
        assert f"{res['mean'][base]:.4f}" in hist and f"{res['mean'][cand]:.4f}" in hist
    by = {(s, r["scene"], r["setting"]): r["marked"] for s in (40, 41, 42) for r in
          result(f"mask_views_clean_G3_s{s}.json")["rows"]}
    scenes = [(s, sc) for s, sc, st in by if st == "base"]
    assert len(scenes) == 45
    mean_added = sum(by[(*k, "ghost_views")] - by[(*k, "base")] for k in scenes) / len(scenes)
    assert f"+{100 * mean_added:.3f} % (45 scenes" in hist
    lund = result("mask_views_lund_clean_G3.json")["mean_marked"]
    assert f"| {100 * lund['base']:.3f} % | {100 * lund['ghost_views']:.3f} % (+0.000" in hist
    cost = result("crosscheck_time_cpu_et_s34.json")
    extra = cost["extra_seconds_per_view_by_setting"]
    assert f"+{extra['crosscheck']:.2f} s with `--crosscheck`, +{extra['ghost_views']:.2f} s" \
        in hist


def test_clean_capture_shares_in_the_fmg_history():
    """docs/history/fmg.md's account of the ghost lines' views on the clean 29-photo capture:
    every share it quotes is the clean-capture file's."""
    res = result("clean_capture_lund_s36.json")
    page = page_text("docs/history/fmg.md")
    m = res["mean"]
    for value, fmt in ((m["marked_network"], "mark {:.3f} %"), (m["added_by_views"],
                       "adding {:.3f} %"), (m["ghost_candidates"], "({:.3f} % of the pixels")):
        assert fmt.format(100 * value) in page, fmt.format(100 * value)
    added = {v: r["added_by_views"] for v, r in res["views"].items() if r["added_by_views"]}
    assert sorted(added) == ["22", "24", "28"]
    assert (f"{100 * added['22']:.2f} % and {100 * added['24']:.2f} % on photos 22 and 24, "
            f"{100 * added['28']:.2f} % on photo 28") in page
    px = {v: (r["added_pixels"], r["added_pixels_touching_network"])
          for v, r in res["views"].items() if r["added_pixels"]}
    total, near = (sum(p[i] for p in px.values()) for i in (0, 1))
    assert (f"of the {spaced(total)} pixels the views added on those three photos, "
            f"{spaced(near)} lie") in page
    assert f"photo 24's {px['24'][0]} pixels do not" in page and px["24"][1] == 0


def test_ghost_touching_counts_in_the_fmg_history():
    """The ghosts build's split of what the views added is the file's, and so are the flare
    IoU figures quoted beside it."""
    res = result("ghost_touching_kinds46.json")
    page = page_text("docs/history/fmg.md")

    a = res["all"]
    assert (f"the views added {spaced(a['touching'] + a['apart'])} pixels to the three "
            f"scenes' masks, {spaced(a['touching'])} of them in regions touching the network's "
            f"marks, {spaced(a['touching_true'])} of those true ghost (and "
            f"{spaced(a['apart_true'])} of the {spaced(a['apart'])} apart)") in page
    rows = result("mask_views_kinds_ghosts_s46.json")["rows"]
    iou = {(r["scene"], r["setting"]): r["flare_iou"] for r in rows}
    for scene in ("et", "lund"):
        assert (f"{iou[(scene + '_ghosts', 'base')]:.3f} to "
                f"{iou[(scene + '_ghosts', 'ghost_views')]:.3f}") in page


def test_streak_lines_candidates_are_their_files():
    """docs/history/fmg.md's verdicts on the streak lines (sixty-second session): A's two
    failing margins on sceaux_castle, and B's table (the judge of three builds, the
    every-kind scenes, the clean photos, the daylight composites), are the committed files'
    numbers; the card and the goals page quote B's streaks and clean sceaux_castle."""
    flat = page_text("docs/history/fmg.md")

    def scenes(name):
        return {(r["scene"], r["streak_lines"]): r
                for r in result(name)["rows"] if r["rays"]}

    def clean(name):
        return {(r["scene"], r["setting"]): r["marked"]
                for r in result(name)["rows"]}

    a, av = scenes("mask_dev_scenes_lines.json"), clean("mask_views_clean_dev_lines.json")
    s0, s1 = a["sceaux_synth", False], a["sceaux_synth", True]
    assert (f"rose from {100 * s0['marked_outside']:.2f} % to {100 * s1['marked_outside']:.2f} "
            f"% (+{100 * (s1['marked_outside'] - s0['marked_outside']):.3f} points") in flat
    assert f"flare IoU {s0['flare_iou']:.3f} to {s1['flare_iou']:.3f}" in flat
    c0, c1 = av["sceaux_ws", "ghost_views"], av["sceaux_ws", "ghost_views_lines"]
    assert f"from {100 * c0:.3f} % to {100 * c1:.3f} % (+{100 * (c1 - c0):.3f})" in flat
    # B
    base, cand = "fmg.safetensors@1", "fmg.safetensors@1+lines"
    judged = failed_streaks_judgement([f"mask_dev_kinds_linesB_s{s}.json" for s in (46, 47, 48)],
                                      base, cand, "mask_kinds_judge_linesB_s62.json",
                                      "three builds", flat)
    k = judged["kinds"]
    assert (f"| 1. ... mean over kinds | {judged['mean'][base]:.4f} | "
            f"{judged['mean'][cand]:.4f} | not lower |") in flat
    b, bv = scenes("mask_dev_scenes_linesB.json"), clean("mask_views_clean_dev_linesB.json")
    names = ("sceaux_synth", "et_synth", "lund_synth")
    for lines in (False, True):
        iou = " / ".join(f"{b[s, lines]['flare_iou']:.3f}" for s in names)
        out = " / ".join(f"{100 * b[s, lines]['marked_outside']:.2f}" for s in names)
        assert f"{iou}; {out} %" in flat, (iou, out)
    for setting in ("ghost_views", "ghost_views_lines"):
        cells = " / ".join(f"{100 * bv[s, setting]:.3f}" for s in ("lund_ws", "sceaux_ws", "et_ws"))
        assert f"{cells} %" in flat, cells
    comp = [{n: v["weights"]["IoU_flare"]
             for n, v in result(f"fmg_dev_per_kind_M_day_rays_{f}.json")["kinds"].items()}
            for f in ("s62", "linesB")]
    for c in comp:
        assert f"{np.mean(list(c.values())):.4f} (streaks {c['streaks']:.3f})" in flat
    fast = result("mask_time_cpu_lines_fast_s62.json")["rows"]
    t = {r.get("rays", "network"): r["median_s_per_view"] for r in fast}
    assert (f"the rays took {t['default']:.3f} s per view and {t['streak_lines']:.3f} s with "
            f"the lines, the network {t['network']:.3f} s") in flat
    s31 = scenes("mask_dev_kinds_linesB_s31_streaks.json")
    cells = [" / ".join(f"{s31[f'{n}_streaks', lines]['flare_iou']:.3f}"
                        for n in ("et", "lund", "sceaux")) for lines in (False, True)]
    assert f"goes from {cells[0]} to {cells[1]} with them" in flat, cells
    quote_streaks_and_sceaux(k, base, cand, bv, "ghost_views_lines")


def test_learned_fusion_table_is_its_file():
    """docs/history/fmg.md's table of the learned fusion held out by workspace (sixty-third
    session's script, run in the sixty-fifth) is the committed file's numbers, and so are the
    differences its text and the card quote."""
    flat = page_text("docs/history/fmg.md")
    card = page_text("gnfr/weights/fmg.md")
    rows = result("mask_fusion_folds_s63.json")["rows"]
    names = {"sceaux": "sceaux_castle", "et": "et", "lund": "lund"}
    by = {}
    for held, name in names.items():
        mine = [r for r in rows if r["held_out"] == held]
        full = sorted((r for r in mine if not r["without"]), key=lambda r: r["fit_seed"])
        bare = sorted((r for r in mine if r["without"]), key=lambda r: r["fit_seed"])
        assert [r["fit_seed"] for r in full] == [0, 1] == [r["fit_seed"] for r in bare]
        assert len({r["stage_mean"] for r in mine}) == 1  # the stage does not depend on the fit
        s = mine[0]

        def pair(rs, f):
            return " / ".join(f(r) for r in rs)

        cells = [name, f"{s['stage_mean']:.3f}",
                 pair(full, lambda r: f"{r['fusion_mean']:.3f}"),
                 pair(bare, lambda r: f"{r['fusion_mean']:.3f}"),
                 f"{s['stage']['ghosts']:.3f}",
                 pair(full, lambda r: f"{r['fusion']['ghosts']:.3f}"),
                 f"{100 * s['clean_stage']:.2f} %",
                 pair(full, lambda r: f"{100 * r['clean_fusion']:.2f}") + " %"]
        row = "| " + " | ".join(cells) + " |"
        assert row in flat, row
        by[held] = (s["stage_mean"], [r["fusion_mean"] for r in full],
                    [r["fusion_mean"] for r in bare])
    st, full, _ = by["et"]
    lo, hi = sorted(st - f for f in full)
    assert f"{lo:.2f}-{hi:.2f} lower on et" in flat
    assert f"et {min(full):.2f}-{max(full):.2f} against {st:.2f} flare IoU" in card
    st, full, bare = by["lund"]
    gain = sorted(f - st for f in full)
    assert f"{gain[0]:.3f}-{gain[1]:.3f} higher on lund" in flat
    assert f"lund +{gain[0]:.3f} to +{gain[1]:.3f}" in card
    lift = sorted(f - b for f, b in zip(full, bare, strict=True))
    assert f"{lift[0]:.3f}-{lift[1]:.3f} higher with them" in flat
    for held in ("sceaux", "et"):
        st, full, bare = by[held]
        assert max(abs(f - b) for f, b in zip(full, bare, strict=True)) <= 0.010 + 5e-4
        assert all(abs(f - st) < 0.01 for f in full) or held == "et"


def test_mask_pads_outcome_is_its_files():
    """`mask --pads` (seventy-second session): the rule's parts recomputed from their files
    (the one-kind judge, the photo judge), and the numbers docs/history/fmg.md, the FMG
    card, docs/options.md and docs/goals.md quote are those files'."""
    history, card = page_text("docs/history/fmg.md"), page_text("gnfr/weights/fmg.md")
    options, goals = page_text("docs/options.md"), page_text("docs/goals.md")
    base, cand = "fmg.safetensors@1", "fmg.safetensors@1+pads=reflect,replicate,constant"
    kinds = load_benchmark("mask_kind_scenes")
    builds = [result(f"mask_dev_kinds_pads_s{s}.json")["rows"]
              for s in (31, 32, 33)]
    again = kinds.judge(builds, base, cand, mean_gain=-0.01)
    saved = result("mask_kinds_judge_pads_s72.json")
    assert again["passes"] == saved["passes"] is True
    assert again["mean"] == pytest.approx(saved["mean"])
    for name in (base, cand):
        assert f"{saved['mean'][name]:.4f}" in history and f"{saved['mean'][name]:.4f}" in options
    m = photo_verdict("s72_pad", "s69_sh", [2, 3], "mask_pads_photo_judge_s72.json",
                      "fails (a)")
    assert (f"{m['psnr_flare']:+.3f} / {m['psnr']:+.3f} / {m['ssim']:+.3f} / "
            f"{m['held']:+.3f} dB") in history
    assert f"lost the flare region by {-m['psnr_flare']:.3f} dB" in history
    assert f"{m['psnr_flare']:.3f} and -0.059 dB against 0.05" in card  # two seeds, s72

    def marked(name):
        rows = result(name)["rows"]
        return {r["scene"].split(".")[0]: f"{100 * r['marked']:.3f} %" for r in rows
                if r["setting"] == "ghost_views_pads"}, result(name)["mean_marked"]

    dev, dev_mean = marked("mask_views_clean_dev_pads_s72.json")
    scenes = f"lund {dev['lund']}, sceaux_castle {dev['sceaux_castle']}, et {dev['et']}"
    assert f"({scenes})" in options and scenes in goals
    pads, plain = (f"{100 * dev_mean[k]:.3f} %" for k in ("ghost_views_pads", "ghost_views"))
    assert f"{pads} of the pixels ({scenes})" in options  # the default since s73
    assert f"marks {pads} of the clean development scenes" in card
    assert f"{pads} of the pixels marked instead of" in options and plain in options
    test, _ = marked("mask_views_clean_test_pads_s72.json")
    for page in (card, goals):
        assert f"kermit {test['kermit']}, cyprus {test['cyprus']}, fern {test['fern']}" in page
    rows = result("mask_time_pads_s72.json")["rows"]
    plain, padded = (next(r["median_s_per_view"] for r in rows if bool(r["pads"]) is p)
                     for p in (False, True))
    assert f"{padded:.2f} s per view instead of {plain:.2f} s" in options
    assert f"{padded:.2f} s per view" in history and f"against {plain:.2f} s" in history


def test_mask_pads_exploration_is_its_file():
    """The seventy-second session's exploration (benchmarks/fmg_pads.py): the figures
    docs/history/fmg.md quotes for the plain pass, the mirrored pass, the consensus and the
    regions kept whole are its file's."""
    history = page_text("docs/history/fmg.md")
    res = result("fmg_pads_explore_s72.json")
    clean, iou = res["clean_marked"], res["synth_flare_iou"]

    def pct(ws, key):
        return f"{100 * clean[ws + '.deflare'][key]:.3f}"

    def ious(key):
        return " / ".join(f"{iou[s + '_synth'][key]:.3f}" for s in ("sceaux", "et", "lund"))

    assert (f"lund {pct('lund', 'plain')} % of the pixels marked as it is, "
            f"{pct('lund', 'reflect')} % mirrored; sceaux_castle {pct('sceaux_castle', 'plain')} "
            f"%, {pct('sceaux_castle', 'reflect')} % mirrored") in history
    assert (f"sceaux_castle {pct('sceaux_castle', 'min')} %, et {pct('et', 'min')} % and lund "
            f"{pct('lund', 'min')} %") in history
    assert f"flare IoU {ious('min')} on sceaux / et / lund (from {ious('plain')}" in history
    assert f"flare IoU is then {ious('regions')} (plain {ious('plain')})" in history
    assert (" / ".join(pct(w, "regions") for w in ("sceaux_castle", "et", "lund"))
            + " % of sceaux_castle / et / lund are marked") in history


def test_mask_pads_regions_outcome_is_its_files():
    """`mask --pads-keep regions` (seventy-second session): both judges recomputed from
    their files, and the numbers the history, the FMG card and docs/options.md quote (the
    two-seed photo part the history alone: the seventy-third session's four seeds replaced
    it on the other pages)."""
    history, card = page_text("docs/history/fmg.md"), page_text("gnfr/weights/fmg.md")
    options = page_text("docs/options.md")
    cand = "fmg.safetensors@1+pads=reflect,replicate,constant+regions"
    builds = [result(f"mask_dev_kinds_pads_s{s}.json")["rows"]
              + result(f"mask_dev_kinds_regions_s{s}.json")["rows"]
              for s in (31, 32, 33)]
    again = load_benchmark("mask_kind_scenes").judge(builds, "fmg.safetensors@1", cand,
                                                      mean_gain=-0.01)
    saved = result("mask_kinds_judge_regions_s72.json")
    assert again["passes"] == saved["passes"] is True
    assert again["mean"] == pytest.approx(saved["mean"])
    kinds = f"{saved['mean'][cand]:.4f}"
    assert kinds in history and kinds in card and kinds in options
    photos = load_benchmark("fmg_photo_ab").judge(RESULTS, "s72_reg", "s69_sh",
                                                  ["sceaux", "et", "lund"], [2, 3], rule="speed")
    saved = result("mask_regions_photo_judge_s72.json")
    assert photos["decision"] == saved["decision"] == "fails (a)"
    m = saved["mean"]
    assert (f"{m['psnr_flare']:+.3f} / {m['psnr']:+.3f} / {m['ssim']:+.3f} / "
            f"{m['held']:+.3f} dB") in history
    clean = result("mask_views_clean_dev_regions_s72.json")
    by = {r["scene"].split(".")[0]: f"{100 * r['marked']:.3f}" for r in clean["rows"]
          if r["setting"] == "ghost_views_pads"}
    assert f"{by['lund']} / {by['sceaux_castle']} / {by['et']} %" in history
    mean = f"{100 * clean['mean_marked']['ghost_views_pads']:.3f} %"
    assert mean in history and mean in card and mean in options


def test_mask_regions_four_seeds_outcome_is_its_files():
    """The seventy-third session's rule: the repeated run equals the sixty-ninth session's,
    the null and the four-seed decision recomputed from the arms' files (joined names), and
    the numbers the history, the FMG card, docs/options.md and docs/goals.md quote."""
    history, card = page_text("docs/history/fmg.md"), page_text("gnfr/weights/fmg.md")
    options, goals = page_text("docs/options.md"), page_text("docs/goals.md")
    same = [result(f"fmg_{a}_fair_et_s2.json")
            for a in ("s69_sh", "s73_re")]
    assert same[0]["inputs"] == same[1]["inputs"] and same[0]["heldout"] == same[1]["heldout"]
    ab = load_benchmark("fmg_photo_ab")
    scenes = ["sceaux", "et", "lund"]
    null = ab.judge(RESULTS, "s73_sh", "s69_sh", scenes, [4, 5], baseline_seeds=[2, 3],
                    rule="speed")
    saved = result("photo_null_judge_s73.json")
    assert null["mean"] == pytest.approx(saved["mean"]) and null["decision"] == "passes"
    n = saved["mean"]
    assert f"mean {n['psnr_flare']:+.3f} / {n['psnr']:+.3f} / {n['held']:+.3f} dB" in history
    dec = ab.judge(RESULTS, "s72_reg:2,3+s73_reg:4,5", "s69_sh:2,3+s73_sh:4,5", scenes, [0],
                   rule="speed")
    saved = result("mask_regions_photo_judge4_s73.json")
    for scene in scenes:
        assert dec["per_scene"][scene] == pytest.approx(saved["per_scene"][scene])
    assert dec["decision"] == saved["decision"] == "passes"
    assert saved["seeds"] == saved["baseline_seeds"] == [2, 3, 4, 5]
    m, sceaux = saved["mean"], saved["per_scene"]["sceaux"]
    row = " | ".join(f"{saved['per_scene'][s]['psnr_flare']:+.3f}" for s in scenes)
    assert f"| flare region of the de-flared photos | {row} | {m['psnr_flare']:+.3f} |" in history
    for page in (history, card, options, goals):
        assert f"{m['psnr_flare']:.3f} dB" in page and f"{m['held']:+.3f} dB" in page
    for page in (card, options):
        assert f"sceaux_castle {sceaux['psnr_flare']:.3f}" in page
    spread = result("photo_spread_s69_sh_s73.json")
    se = spread["se_mean_difference"]
    assert f"standard error of {se['2']['psnr_flare']:.3f} dB" in card
    assert f"{se['4']['psnr_flare']:.3f} for four" in card
    test = result("mask_views_clean_test_regions_s73.json")
    by = {r["scene"].split(".")[0]: f"{100 * r['marked']:.3f} %" for r in test["rows"]
          if r["setting"] == "ghost_views_pads"}
    for page in (card, goals):
        assert all(f"{s} {by[s]}" in page for s in ("kermit", "cyprus", "fern"))
    assert f"{100 * test['mean_marked']['ghost_views_pads']:.3f} %" in options


def test_mask_pixels_four_seeds_outcome_is_its_files():
    """The seventy-third session's second rule: `--pads-keep pixels` against the regions on
    four seeds recomputed from the arms' files, the plain-run comparison too, and the
    numbers the history, the FMG card, docs/options.md and docs/goals.md quote."""
    history, card = page_text("docs/history/fmg.md"), page_text("gnfr/weights/fmg.md")
    options, goals = page_text("docs/options.md"), page_text("docs/goals.md")
    ab = load_benchmark("fmg_photo_ab")
    scenes = ["sceaux", "et", "lund"]
    cand = "s72_pad:2,3+s73_pad:4,5"
    for base, name in (("s72_reg:2,3+s73_reg:4,5", "mask_pixels_photo_judge4_s73.json"),
                       ("s69_sh:2,3+s73_sh:4,5", "mask_pixels_vs_plain_judge4_s73.json")):
        again = ab.judge(RESULTS, cand, base, scenes, [0], rule="speed")
        saved = result(name)
        assert again["decision"] == saved["decision"] == "passes"
        for scene in scenes:
            assert again["per_scene"][scene] == pytest.approx(saved["per_scene"][scene])
    rule = result("mask_pixels_photo_judge4_s73.json")
    row = " | ".join(f"{rule['per_scene'][s]['psnr_flare']:+.3f}" for s in scenes)
    m = rule["mean"]
    assert f"| flare region of the de-flared photos | {row} | {m['psnr_flare']:+.3f} |" in history
    assert (f"the photos' flare region {-m['psnr_flare']:+.3f} dB and the whole photo "
            f"{-m['psnr']:+.3f} dB") in options  # the regions against the default
    plain = result("mask_pixels_vs_plain_judge4_s73.json")
    p, sceaux = plain["mean"], plain["per_scene"]["sceaux"]["psnr_flare"]
    for page in (history, card, options, goals):
        assert f"flare region {p['psnr_flare']:+.3f} dB (sceaux_castle {sceaux:+.3f})" in page
        assert f"{p['held']:+.3f} dB" in page and f"{p['psnr']:+.3f} dB" in page


def test_target_rule_outcome_is_its_files():
    """The seventy-fourth session's rule (the 10 % rule counting the plain run's marks too):
    the judge recomputed from the arms' files fails as saved, the numbers the history quotes
    are those files', the repeat on et is exact, and the targets against the truth are
    target_rule_s74.json's."""
    history = page_text("docs/history/fmg.md")
    ab = load_benchmark("fmg_photo_ab")
    for base, name in (("s72_pad:2,3+s73_pad:4,5", "target_rule_photo_judge4_s74.json"),
                       ("s69_sh:2,3+s73_sh:4,5", "target_rule_vs_plain_judge4_s74.json")):
        again = ab.judge(RESULTS, "s74_cnt", base, ["sceaux"], [2, 3, 4, 5], rule="speed")
        saved = result(name)
        assert again["decision"] == saved["decision"] and saved["decision"].startswith("fails")
        assert again["per_scene"]["sceaux"] == pytest.approx(saved["per_scene"]["sceaux"])
    m = result("target_rule_photo_judge4_s74.json")["mean"]
    assert (f"flare region of the de-flared photos {m['psnr_flare']:+.3f} dB (needed >= "
            f"-0.05), whole photo {m['psnr']:+.3f}") in history
    assert f"held-out views {m['held']:+.3f}" in history
    card = page_text("gnfr/weights/fmg.md")
    assert f"lost more ({m['psnr_flare']:+.3f} dB against the default on four seeds" in card
    p = result("target_rule_vs_plain_judge4_s74.json")["mean"]
    assert (f"flare region {p['psnr_flare']:+.3f} dB, whole photo {p['psnr']:+.3f}, "
            f"held-out views {p['held']:+.3f}") in history
    et = result("fmg_s74_cnt_fair_et_s2.json")
    base = result("fmg_s72_pad_fair_et_s2.json")
    assert et["inputs"] == base["inputs"] and et["heldout"] == base["heldout"]

    def view(arm: str, seed: int) -> float:
        run = result(f"fmg_{arm}_fair_sceaux_s{seed}.json")
        return run["inputs"]["views"]["100_7105"]["psnr_flare"]

    own = [np.mean([view(a, s) for a, s in arms]) for arms in (
        [("s74_cnt", s) for s in (2, 3, 4, 5)],
        [("s72_pad", 2), ("s72_pad", 3), ("s73_pad", 4), ("s73_pad", 5)],
        [("s69_sh", 2), ("s69_sh", 3), ("s73_sh", 4), ("s73_sh", 5)])]
    assert (f"{own[0]:.2f} dB on the four seeds against {own[1]:.2f} as a target (the plain "
            f"run's arms: {own[2]:.2f})") in history
    rows = result("target_rule_s74.json")["workspaces"]
    over = {Path(r["workspace"]).name: r["targets_over_truth"] for r in rows}
    assert [over[f"sceaux_{a}_s2.ws"] for a in ("s69_sh", "s72_pad", "s74_cnt")] == [4, 5, 4]
    assert over["et_s69_sh_s2.ws"] == over["et_s72_pad_s2.ws"] == 0
    assert over["lund_s69_sh_s2.ws"] == over["lund_s72_pad_s2.ws"] == 1
    assert all(r["kept_out_under_truth"] == 0 for r in rows)


def test_light_cores_verdict_is_the_judge_of_the_committed_scores():
    """The seventy-fifth session's rule for `mask --light-cores`, scored in the
    seventy-seventh: the pooled one-kind table is the judge of the three builds' files
    (judged again here), part 2's rows are identical view by view, part 3's shares are
    the file's; the candidate fails part 1, as the page, the options and the card say."""
    mk = load_benchmark("mask_kind_scenes")
    flat = page_text("docs/history/fmg.md")
    builds = [mk.build_rows(str(RESULTS / f"mask_dev_kinds_cores_s{s}_s77.json"))
              for s in (31, 32, 33)]
    base = "fmg.safetensors@1+pads=reflect,replicate,constant"
    cand = "fmg.safetensors@1+cores+pads=reflect,replicate,constant"
    res = mk.judge(builds, base, cand, target="streaks", target_gain=0.01)
    saved = result("mask_kinds_judge_cores_s77.json")
    assert res["mean"] == saved["mean"] and res["passes"] is saved["passes"] is False
    kinds = saved["kinds"]
    assert f"streaks | {kinds['streaks'][base]:.4f} | {kinds['streaks'][cand]:.4f} |" in flat
    assert f"| {res['mean'][base]:.4f} | {res['mean'][cand]:.4f} | not lower |" in flat
    others = ("starburst", "ghosts", "glare", "scatter")
    for arm in (base, cand):
        assert " / ".join(f"{kinds[k][arm]:.4f}" for k in others) in flat
    rows = result("mask_dev_scenes_cores_s77.json")["rows"]
    by = {(r["scene"], r["light_cores"]): r for r in rows if r["rays"]}
    for scene in ("sceaux_synth", "et_synth", "lund_synth"):  # part 4 held by identity
        plain, cores = by[(scene, False)], by[(scene, True)]
        assert plain["per_view"] == cores["per_view"]
        assert plain["flare_iou"] == cores["flare_iou"]
    options = page_text("docs/options.md")
    for cell in clean_triples("mask_views_clean_dev_cores_s77.json",
                              ("ghost_views_pads", "ghost_views_pads_cores")):
        assert cell in flat and cell in options, cell


def test_glow_probe_table_is_its_files():
    """docs/history/fmg.md's eighty-ninth-session table of the glow probe: each cell is its
    scene's file, the quoted distances of the missed flare are theirs, and the finding the
    text draws holds (each probe lowers flare IoU, and most of what it adds is not flare)."""
    history = page_text("docs/history/fmg.md")
    names = {"sceaux": "sceaux_castle", "et": "et", "lund": "lund"}
    far, near, left = [], [], []
    for scene, name in names.items():
        rec = result(f"glow_probe_{scene}_s89.json")
        sc = rec["scores"]
        base, ring, views = sc["mask stage"], sc["ring"], sc["views"]
        row = (f"| {name} | {base['iou']:.3f} / {base['light_left']:.3f} | "
               f"{ring['iou']:.3f} / {ring['light_left']:.3f}, adds {ring['added']:.3f}"
               + (" of the view, " if scene == "sceaux" else ", ")
               + f"{ring['added_on_flare']:.3f}" + (" of it flare" if scene == "sceaux"
                                                     else " flare")
               + f" | {views['iou']:.3f} / {views['light_left']:.3f}, adds "
               f"{views['added']:.3f}, {views['added_on_flare']:.3f} flare |")
        assert row in history, row
        for probe in (ring, views):
            assert probe["iou"] < base["iou"] and probe["added_on_flare"] < 0.1
        far.append(f"{rec['missed_by_distance']['0.1-0.2']:.3f}")
        near.append(f"{rec['missed_by_distance']['0.0-0.05']:.3f}")
        left.append(f"{base['light_left']:.3f}")
    assert f"({' / '.join(far)} of them; nearer than a twentieth, {' / '.join(near)}" in history
    assert f"`light_left` below: {' / '.join(left)}," in history


def test_streak_scales_clean_part_and_real_photos_are_their_files():
    """docs/history/fmg.md, "Ninety-sixth session" (and the card, options.md, goals.md): the
    clean-photo part of `mask --streak-scales 1,0.25` (each scene's mean share with the
    streak lines alone and with the scales, lund's largest view, the verdict against the
    plan's 0.05 points) and the real night photos' shares against the default's file."""
    rec = result("mask_views_clean_dev_streak_scales_s96.json")
    assert rec["code"]["commit"].startswith("82616f4") and not rec["code"]["dirty"]
    by = {(r["scene"], r["setting"]): r for r in rec["rows"]}
    base, cand = "ghost_views_pads_lines", "ghost_views_pads_lines_scaled"
    assert by["lund_ws", cand]["streak_scales"] == [1.0, 0.25]
    assert by["lund_ws", base]["streak_lines"] and by["lund_ws", base]["streak_scales"] is None
    hist = page_text("docs/history/fmg.md")
    pages = [page_text(p) for p in ("gnfr/weights/fmg.md", "docs/options.md", "docs/goals.md")]
    lund = [100 * by["lund_ws", s]["marked"] for s in (base, cand)]
    worst = [100 * max(v["marked"] for v in by["lund_ws", s]["per_view"].values())
             for s in (base, cand)]
    et = [100 * by["et_ws", s]["marked"] for s in (base, cand)]
    assert f"from {lund[0]:.3f} % to {lund[1]:.3f} % there" in hist
    assert f"(+{lund[1] - lund[0]:.3f} points against the 0.05 allowed)" in hist
    assert lund[1] - lund[0] > 0.05  # the part fails
    assert f"its largest view from {worst[0]:.3f} % to {worst[1]:.2f} %" in hist
    assert max(worst) < 10 and "No view is over the 10 % rule" in hist
    assert f"et is unchanged at {et[0]:.3f} %" in hist and f"{et[0]:.3f}" == f"{et[1]:.3f}"
    assert f"lund {lund[1]:.3f} % of the pixels against {lund[0]:.3f} %" in pages[1]
    assert f"its largest view {worst[1]:.2f} %" in pages[1]
    assert all(f"{lund[1]:.3f} % against {lund[0]:.3f} %" in p for p in (pages[0], pages[2]))
    real = result("fmg_real_flare_streak_scales_s96.json")
    assert "--streak-scales 1,0.25" in real["command"] and real["pads"] == [
        "reflect", "replicate", "constant"]
    new = [100 * v for k, v in sorted(real["marked"].items())]
    old = [100 * v for k, v in sorted(result("fmg_real_flare_M_F26_s79.json")["marked"].items())
           if k.endswith("/fmg.safetensors")]
    assert (f"{new[0]:.2f} % and {new[1]:.2f} % of the two frames are marked, against "
            f"{old[0]:.2f} % and {old[1]:.2f} % at the default") in hist
    assert (f"{new[0]:.2f} % and {new[1]:.2f} % of the frames are marked, against "
            f"{old[0]:.2f} % and {old[1]:.2f} %") in pages[0]
    assert all(f"{new[1]:.2f} % of the frame against {old[1]:.2f} %" in p for p in pages[1:])


def test_streak_scales_time_is_its_files():
    """docs/history/fmg.md and docs/options.md: the rays' time per view at the stage's rule,
    with the streak lines and with them at a quarter too, and the network's."""
    hist, opts = page_text("docs/history/fmg.md"), page_text("docs/options.md")
    got = {}
    for where in ("lund", "real"):
        rec = result(f"mask_time_cpu_streak_scales_{where}_s96.json")
        assert rec["code"]["commit"].startswith("dd05e68") and not rec["code"]["dirty"]
        rays = {r["rays"]: r["median_s_per_view"] for r in rec["rows"] if "rays" in r}
        net = [r["median_s_per_view"] for r in rec["rows"] if "weights" in r]
        got[where] = ([rays[k] for k in ("default", "streak_lines",
                                         "streak_lines_at_1,0.25")], net[0])
    (l0, l1, l2), ln = got["lund"]
    (r0, r1, r2), rn = got["real"]
    assert (f"the flare rays take {l0:.3f} s per view (median) at the stage's rule, {l1:.3f} s "
            f"with the streak lines and {l2:.3f} s with them also at a quarter") in hist
    assert f"the same are {r0:.3f}, {r1:.3f} and {r2:.3f} s" in hist
    assert f"against {ln:.3f} and {rn:.3f} s for the network alone" in hist
    assert "costs about half as much again as the streak lines themselves" in hist
    assert 0.4 < (l2 - l1) / (l1 - l0) < 0.7 and 0.4 < (r2 - r1) / (r1 - r0) < 0.7
    assert f"{l1:.3f} s a view with the streak lines, {l2:.3f} s with the quarter too" in opts
    assert f"about {l2 - l1:.1f} s per view to the streak lines' {l1 - l0:.1f}" in opts


def test_night_photos_are_no_darker_than_daylight_ones():
    """docs/history/fmg.md, "Ninety-seventh session": each folder's row is the luminance
    file's range (three decimals), and the verdict holds: the real night photos' darkest
    median lies above a daylight scene's darkest and their brightest below a daylight
    scene's brightest, so no brightness cut splits them."""
    folders = result("scene_luminance_s97.json")["folders"]
    by_name = {Path(k).parts[-1] if Path(k).name != "images" else Path(k).parts[-2]: v
               for k, v in folders.items()}
    by_name["fern"] = by_name.pop("images_8")
    text = page_text("docs/history/fmg.md")
    for name, stats in by_name.items():
        label = "flare_real (the real night photos)" if name == "flare_real" else name
        row = (f"| {label} | {len(stats['photos'])} | {stats['median_min']:.3f} to "
               f"{stats['median_max']:.3f} |")
        assert row in text, row
    night = by_name.pop("flare_real")
    assert any(d["median_min"] < night["median_min"] for d in by_name.values())
    assert any(d["median_max"] > night["median_max"] for d in by_name.values())
    assert any(d["median_min"] < night["median_max"] < d["median_max"]
               for d in by_name.values())
