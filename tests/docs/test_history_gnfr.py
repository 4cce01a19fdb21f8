"""docs/history/gnfr.md and pose.md, the fine-tune and pretraining levers (docs/presets.md,
docs/options.md, the GN-FR card): the tables and verdicts they quote are the result files'
and judges'.

As tests/docs/test_history.py; split from it by topic in the ninety-fourth session.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.conftest import load_benchmark
from tests.docs.numbers import (
    REPO,
    RESULTS,
    page_text,
    result,
)


def test_pose_passes_table_is_their_files():
    """docs/history/pose.md's table of the mapping passes: every row's image count, each
    pass's registered count and reference errors where quoted are the benchmark's files, and
    so is the one comparison of kept models the text quotes."""
    import re

    text = (REPO / "docs" / "history" / "pose.md").read_text()  # its table by lines
    files = {size: result(f"pose_passes_dev_{size}.json")["scenes"]
             for size in ("1008", "504")}
    rows = [r for r in text.splitlines() if re.match(r"\| [a-z_]+ \(\d+\) \|", r)]
    assert len(rows) == 12
    for line in rows:
        cells = [c.strip() for c in line.strip("|").split("|")]
        scene, shown = re.match(r"([a-z_]+) \((\d+)\)", cells[0]).groups()
        res = files["504" if shown == "504" else "1008"][scene]
        assert cells[1] == str(res["images"]), line
        for init, cell in zip(("default", "relaxed", "loose"), cells[2:5], strict=True):
            p = res["passes"][init]
            assert int(cell.split()[0]) == p["registered"], (line, init)
            pair = re.search(r"\(([\d.]+), ([\d.]+)\)", cell)
            if pair:
                e = p["errors"]
                assert pair.groups() == (f"{e['rotation_deg_median']:.3f}",
                                         f"{e['centre_median']:.4f}"), (line, init)
    kept = files["504"]["lund"]["kept_against_kept_without"]
    page = " ".join(text.split())
    assert f"within {kept['rotation_deg_median']:.3f} degrees (largest " \
           f"{kept['rotation_deg_max']:.3f}) and {kept['centre_median']:.4f} of the walk" in page


def test_ema_rule_table_is_the_judges_file_and_both_rules_fail():
    """docs/presets.md, "A running average of the weights": the table is the photo rule's
    judge file, recomputed from the committed runs; both rules fail (a)."""
    presets = page_text("docs/presets.md")
    res = result("ema_judge_flare_s44.json")
    novel = result("ema_judge_novel_s44.json")
    assert res["decision"] == "fails (a)" == novel["decision"]
    names = {"sceaux": "sceaux_castle", "et": "et", "lund": "lund"}
    for k, d in [*res["per_scene"].items(), ("mean", res["mean"])]:
        row = (f"| {names.get(k, k)} | {d['psnr_flare']:+.3f} | {d['psnr']:+.3f} | "
               f"{d['ssim']:+.3f} | {d['held']:+.3f} |")
        assert row in presets, row
    judge = load_benchmark("fmg_photo_ab").judge
    for rule, r in (("flare", res), ("novel", novel)):
        again = judge(RESULTS, "s44_ema", "s44_base", ["sceaux", "et", "lund"], [6, 7],
                      rule=rule)
        assert again["mean"] == pytest.approx(r["mean"]) and again["decision"] == r["decision"]
    assert f"(+{res['mean']['psnr_flare']:.3f} dB where +0.10 is asked)" in presets
    assert f"({novel['mean']['held']:+.3f} dB where +0.10 is asked)" in presets
    goals = page_text("docs/goals.md")
    assert (f"flare region {res['mean']['psnr_flare']:+.3f} dB and novel views "
            f"{novel['mean']['held']:+.3f} dB on the development mean") in goals


def test_continuation_table_is_its_files():
    """docs/history/gnfr.md's table of a fine-tune carried without its optimizer state (the
    sixty-fifth session) is the two committed evaluations' numbers, the continued one's
    provenance says it went on at step 1 500 with a fresh optimizer, and the differences the
    text and the card quote are theirs."""
    flat = page_text("docs/history/gnfr.md")
    card = page_text("gnfr/weights/gnfr.md")
    runs = [result(f"continuation_et_{n}_s65.json")["methods"]["gnfr"]
            for n in ("straight", "continued")]
    for name, g in zip(("straight to 3 000 steps", "stopped at 1 500, went on from its "
                        "weights (fresh Adam)"), runs, strict=True):
        h, i = g["heldout"], g["inputs"]
        row = (f"| {name} | {h['psnr']:.2f} / {h['ssim']:.4f} | {i['psnr']:.2f} / "
               f"{i['ssim']:.4f} | {i['psnr_flare']:.2f} |")
        assert row in flat, row
    a, b = runs
    trained = b["provenance"]["trained"]
    assert [(r["at_step"], r["optimizer"]) for r in trained["resumed"]] == [(1500, "fresh")]
    assert trained["steps_done"] == 3000 and "resumed" not in a["provenance"]["trained"]
    assert f"({trained['train_seconds']:,.1f} s;".replace(",", " ") in flat
    held = b["heldout"]["psnr"] - a["heldout"]["psnr"]
    flare = b["inputs"]["psnr_flare"] - a["inputs"]["psnr_flare"]
    assert abs(held) < 0.2 and abs(flare) < 0.2  # the rule the text says was met
    assert f"Held-out views {held:+.2f} dB, the flare region {flare:+.2f} dB" in flat
    assert f"held-out {held:+.2f} dB, flare region {flare:+.2f} dB" in card


def exposure_diagnosis_rows() -> list[str]:
    """The rows of docs/history/gnfr.md's lund exposure diagnosis (sixty-sixth session), each
    built from the committed round-trip file and the arms' score files."""
    rt = result("exposure_roundtrip_lund_s66.json")
    arms = {n: result(f"fmg_s66_{n}_fair_lund_s2.json")["inputs"]
            for n in ("gains", "curves", "truth", "gains_nocm")}
    split = rt["deflared"]
    rows = []
    for v, g in split["gains"]["views"].items():
        slope = rt["models"]["view-curves"][v]["transform"][3]
        gain = rt["models"]["gain"][v]
        delta = arms["curves"]["views"][v]["psnr_flare"] - arms["gains"]["views"][v]["psnr_flare"]
        for n, a in arms.items():  # the split's region is the scorer's
            assert split[n]["views"][v]["psnr_region"] == pytest.approx(
                a["views"][v]["psnr_flare"], abs=2e-3)
        names = ("gains", "curves", "truth", "gains_nocm")
        psnr = " / ".join([f"{split[n]['views'][v]['psnr_region']:.2f}" for n in names]
                          + [f"{g['psnr_perfect_fill']:.2f}"])
        offset = " / ".join([f"{255 * np.mean(split[n]['views'][v]['bias_region']):+.1f}"
                             for n in names] + [f"{255 * np.mean(g['bias_perfect_fill']):+.1f}"])
        rows.append(f"| {v} | {slope:.2f} | {gain['transform'][1]:.2f} | "
                    f"{100 * gain['clipped']:.1f} % | {100 * g['share_reached']:.0f} % | "
                    f"{delta:+.2f} | {psnr} | {offset} | {rt['flare_outside'][v]:.1f} |")
    return rows


def test_lund_exposure_diagnosis_table_is_its_files():
    """docs/history/gnfr.md's per-view table of lund's exposure diagnosis (sixty-sixth
    session) is the round-trip benchmark's file and the arms' scores; the means the text
    quotes are theirs."""
    flat = page_text("docs/history/gnfr.md")
    for row in exposure_diagnosis_rows():
        assert row in flat, row
    for n in ("gains", "curves", "truth", "gains_nocm"):
        a = result(f"fmg_s66_{n}_fair_lund_s2.json")
        words = (f"{n}: flare region {a['inputs']['psnr_flare']:.2f} dB, whole photo "
                 f"{a['inputs']['psnr']:.2f} dB, held-out views {a['heldout']['psnr']:.2f} dB")
        assert words in flat, words
    gains = result("exposure_roundtrip_lund_s66.json")["deflared"]["gains"]
    perfect = np.mean([r["psnr_perfect_fill"] for r in gains["views"].values()])
    assert f"a perfect fill would score {perfect:.2f} dB" in flat
    g, c, t = (result(f"fmg_s66_{n}_fair_lund_s2.json")
               for n in ("gains", "curves", "truth"))
    assert (f"the curves lose {g['inputs']['psnr_flare'] - c['inputs']['psnr_flare']:.2f} dB "
            f"in the flare region") in flat
    assert f"{g['inputs']['psnr'] - c['inputs']['psnr']:.2f} dB on the whole photo" in flat
    assert f"gain {c['heldout']['psnr'] - g['heldout']['psnr']:.2f} dB on the held-out" in flat
    gain = t["inputs"]["psnr_flare"] - g["inputs"]["psnr_flare"]
    assert f"(the flare region +{gain:.2f} dB)" in flat


def _arm_runs(arm: str, scene: str, seeds=(2, 3)) -> list[dict]:
    """One arm's ``fmg_photo_ab.py`` result files on one scene, in the order of ``seeds``."""
    return [result(f"fmg_{arm}_fair_{scene}_s{s}.json")
            for s in seeds]


def _arm_cell(arm: str, scene: str, seeds=(2, 3)) -> str:
    """A history table's cell for one arm on one scene: the seed means of the de-flared
    photos' flare region / whole photo, held-out views (dB), from its ``fmg_photo_ab.py``
    files."""
    runs = _arm_runs(arm, scene, seeds)
    m = [np.mean([r["inputs"]["psnr_flare"] for r in runs]),
         np.mean([r["inputs"]["psnr"] for r in runs]),
         np.mean([r["heldout"]["psnr"] for r in runs])]
    return f"{m[0]:.2f} / {m[1]:.2f}, {m[2]:.2f}"


def _assert_arm_rows(history: str, arms: tuple[str, ...],
                     scenes=("sceaux", "et", "lund")) -> None:
    """Each scene's row of a history table of seed means, one ``_arm_cell`` per arm, is on
    the page."""
    for sc in scenes:
        row = f"| {sc} | " + " | ".join(_arm_cell(a, sc) for a in arms) + " |"
        assert row in history, row


def _seed_diffs(baseline: str, candidate: str, part: str, key: str,
                scenes=("sceaux", "et", "lund")) -> list[float]:
    """Per scene and seed, the candidate arm's ``part``/``key`` minus the baseline's."""
    return [b[part][key] - a[part][key] for sc in scenes
            for a, b in zip(_arm_runs(baseline, sc), _arm_runs(candidate, sc), strict=True)]


def test_flare_fallback_and_inputs_sources_table_is_its_files():
    """docs/history/gnfr.md's sixty-seventh-session table (seed means of the baseline, the
    `darkest` fallback and 12 sources for the de-flared photos) is the arms' files; both
    judge files are recomputed from them and their decisions and means are the ones the page
    and docs/options.md quote; the coverage, offset and timing numbers are their files'."""
    history = page_text("docs/history/gnfr.md")
    options = page_text("docs/options.md")
    scenes = ("sceaux", "et", "lund")

    for sc in scenes:
        row = f"| {sc} | " + " | ".join(_arm_cell(f"s67_{a}", sc)
                                        for a in ("base", "dark", "in12")) + " |"
        assert row in history, row
    judge = load_benchmark("fmg_photo_ab").judge
    for name, cand, rule, verdict in (("flare_fallback_judge_s67.json", "s67_dark", "flare",
                                       "fails (a)"),
                                      ("inputs_sources_judge_s67.json", "s67_in12", "depth",
                                       "passes")):
        res = result(name)
        again = judge(RESULTS, cand, "s67_base", list(scenes), [2, 3], rule=rule)
        assert again["decision"] == res["decision"] == verdict
        assert again["mean"] == pytest.approx(res["mean"])
    dark = result("flare_fallback_judge_s67.json")
    assert not any(dark["parts"][p] for p in "abc")
    assert (f"the flare region {dark['mean']['psnr_flare']:+.3f} dB on the mean, lund "
            f"{dark['per_scene']['lund']['psnr_flare']:+.3f}") in history
    assert f"the whole photo {dark['mean']['psnr']:+.3f}" in history
    assert f"flare region {dark['mean']['psnr_flare']:+.3f} dB on the development" in options
    lund3 = [result(f"fmg_s67_{a}_fair_lund_s3.json")["inputs"]
             ["psnr_flare"] for a in ("base", "dark")]
    assert f"(seed 3: {lund3[1] - lund3[0]:+.2f})" in history
    src = result("inputs_sources_judge_s67.json")
    ps = src["per_scene"]
    assert (f"the flare region {src['mean']['psnr_flare']:+.3f} dB on the mean (sceaux "
            f"{ps['sceaux']['psnr_flare']:+.3f}, lund {ps['lund']['psnr_flare']:+.3f}, et "
            f"{ps['et']['psnr_flare']:+.3f}") in history
    assert (f"the whole photo {src['mean']['psnr']:+.3f}, SSIM {src['mean']['ssim']:+.4f} "
            f"(lund {ps['lund']['ssim']:+.4f}), the held-out views the baseline's") in history
    assert all(d["held"] == 0 and d["held_ssim"] == 0 for d in ps.values())
    assert f"rose {src['mean']['psnr_flare']:.2f} dB on the development scenes' mean (lund " \
           f"{ps['lund']['psnr_flare']:+.2f}" in options
    cov = {n: result(f"flare_coverage_lund_s67_n{n}.json")
           for n in (6, 9, 12)}
    assert (f"{100 * cov[6]['mean']:.1f} % of the points along the rays through the true flare "
            f"regions are on flare in every one of the 6 sources") in history
    assert f"{100 * cov[9]['mean']:.1f} % with 9 sources, {100 * cov[12]['mean']:.1f} % with " \
           "12" in history
    worst = [100 * cov[6]["views"][v] for v in ("02", "03", "04", "05")]
    assert f"views 02-05: {int(min(worst))}-{round(max(worst))} %" in history
    assert f"(lund {round(100 * cov[12]['mean'])} % against {round(100 * cov[6]['mean'])} %)" \
        in options
    sce = [result(f"flare_coverage_sceaux_s67_n{n}.json")["mean"]
           for n in (6, 12)]
    assert f"sceaux's barely move, {100 * sce[0]:.2f} % to {100 * sce[1]:.2f} %" in history
    rt = result("exposure_roundtrip_lund_s67.json")["deflared"]
    level = {k: {v: 255 * np.mean(r["bias_region"]) for v, r in rt[k]["views"].items()}
             for k in ("base", "rrdark")}
    assert max(abs(level["base"][v] - level["rrdark"][v]) for v in level["base"]) < 1
    early = [level["base"][v] for v in ("01", "02", "03", "04", "05", "07", "08")]
    assert f"{min(early):.1f}-{max(early):.1f} sRGB levels brighter" in history
    rr = [result(f"fmg_s67_{a}_fair_lund_s2.json")["inputs"]
          ["psnr_flare"] for a in ("base", "base_rrdark", "base_rr12")]
    assert f"region by {rr[1] - rr[0]:+.2f} dB, and its mean offset" in history
    assert f"raised lund's flare region by {rr[2] - rr[0]:.2f} dB" in history
    t = result("inputs_sources_time_lund_s67.json")
    assert t["photos"] == 13
    assert (f"lund's 13 de-flared photos at 504 px render in {t['seconds']['12']:.1f} s against "
            f"{t['seconds']['6']:.1f} s") in history
    assert f"render in about {t['seconds']['12'] / t['seconds']['6']:.1f}x the time" in options
    start, head = (result(f"sample_oneshot_cpu_s67_{n}.json")
                   for n in ("start", "head"))
    assert start["mean"]["psnr_input"] == head["mean"]["psnr_input"]  # the same photos
    assert (f"the de-flared photos {head['mean']['psnr']:.2f} dB against "
            f"{start['mean']['psnr']:.2f} over the whole photo, "
            f"{head['mean']['psnr_flare']:.2f} against {start['mean']['psnr_flare']:.2f} in the "
            f"flare region; their render {head['stages']['render:inputs']['seconds']:.1f} s "
            f"against {start['stages']['render:inputs']['seconds']:.1f} s") in history
    def lund_means(arm):
        runs = _arm_runs(f"s67_{arm}", "lund")
        return {k: np.mean([r[part][m] for r in runs]) for k, part, m in (
            ("flare", "inputs", "psnr_flare"), ("whole", "inputs", "psnr"),
            ("held", "heldout", "psnr"), ("held_ssim", "heldout", "ssim"))}

    v12, in12, base = lund_means("v12"), lund_means("in12"), lund_means("base")
    assert (f"flare region {v12['flare']:.2f} dB against {in12['flare']:.2f} with the same 12 "
            f"sources at render, the whole photo {v12['whole']:.2f} against "
            f"{in12['whole']:.2f}, the held-out views {v12['held']:.2f} dB against "
            f"{base['held']:.2f} (SSIM {v12['held_ssim']:.4f} against "
            f"{base['held_ssim']:.4f})") in history
    rr12 = result("fmg_s67_base_rr12_fair_lund_s2.json")
    base2 = result("fmg_s67_base_fair_lund_s2.json")
    assert f"cost lund's held-out views " \
           f"{base2['heldout']['psnr'] - rr12['heldout']['psnr']:.2f} dB" in history
    def levels(arm, part):
        return {v: 255 * np.mean(r[f"bias_{part}"]) for v, r in rt[arm]["views"].items()
                if f"bias_{part}" in r}

    shares = [100 * r["share_left"] for r in rt["base"]["views"].values()]
    assert f"the mask misses {round(min(shares))}-{round(max(shares))} % of each true region" \
        in history
    left = levels("base", "left")
    assert left == levels("in12", "left")  # the same masks leave the same pixels
    assert f"with {min(left.values()):.1f}-{max(left.values()):.1f} levels of flare" in history
    b6, b12 = levels("base", "blended"), levels("in12", "blended")
    assert (f"the offset is {min(b6.values()):.1f}-{max(b6.values()):.1f} levels with 6 "
            f"sources and {min(b12.values()):.1f}-{max(b12.values()):.1f} with 12 (view 05: "
            f"{b6['05']:.1f} to {b12['05']:.1f})") in history


def test_source_flare_and_flare_flag_table_is_their_files():
    """docs/history/gnfr.md's sixty-eighth-session table (seed means of the baseline, the
    flared twins and the twins with the flare flag) is the arms' files; both judge files are
    recomputed from them with the decisions and means the page quotes; the drawn part's
    offsets and the veil are the round trip's file."""
    history = page_text("docs/history/gnfr.md")
    scenes = ("sceaux", "et", "lund")

    for sc in scenes:
        row = f"| {sc} | " + " | ".join(_arm_cell(a, sc) for a in ("s67_in12", "s68_sf5",
                                                                   "s68_ff"))
        assert row + " |" in history, row
    judge = load_benchmark("fmg_photo_ab").judge
    res = {}
    for name, cand in (("source_flare_judge_s68.json", "s68_sf5"),
                       ("flare_flag_judge_s68.json", "s68_ff")):
        res[cand] = result(name)
        again = judge(RESULTS, cand, "s67_in12", list(scenes), [2, 3], rule="flare")
        assert again["decision"] == res[cand]["decision"] == "fails (a)"
        assert again["mean"] == pytest.approx(res[cand]["mean"])
    sf, ff = res["s68_sf5"], res["s68_ff"]
    assert (f"the flare region {sf['mean']['psnr_flare']:+.3f} dB on the mean with the twins "
            f"alone (sceaux {sf['per_scene']['sceaux']['psnr_flare']:+.3f}), "
            f"{ff['mean']['psnr_flare']:+.3f} with the flag as well (sceaux "
            f"{ff['per_scene']['sceaux']['psnr_flare']:+.3f}, et "
            f"{ff['per_scene']['et']['psnr_flare']:+.3f}, lund "
            f"{ff['per_scene']['lund']['psnr_flare']:+.3f})") in history
    rt = result("exposure_roundtrip_lund_s68.json")
    drawn = {k: {v: 255 * np.mean(r["bias_drawn"]) for v, r in rt["deflared"][k]["views"].items()}
             for k in ("in12", "sf5", "ff")}
    assert len(drawn["in12"]) == 11
    means = [np.mean(list(drawn[k].values())) for k in ("in12", "sf5", "ff")]
    assert (f"({means[0]:.1f} sRGB levels above the truth in the baseline, {means[1]:.1f} with "
            f"the twins, {means[2]:.1f} with the flag as well; view 04: "
            f"{drawn['in12']['04']:.1f}, {drawn['sf5']['04']:.1f}, {drawn['ff']['04']:.1f})"
            ) in history
    veil = [v for s, v in rt["flare_outside"].items() if s in drawn["in12"]]
    assert f"adds {min(veil):.1f}-{max(veil):.1f} levels on the mean of each view" in history


def _judged_against_in12(history: str, candidate: str, judge_file: str) -> dict:
    """A sixty-eighth-session candidate's table rows (baseline ``s67_in12`` and it, every
    development scene) are in ``history``, and its judge file is what ``fmg_photo_ab.py
    judge --rule flare`` recomputes from the arms (verdict "fails (a)"); returns the file."""
    scenes = ("sceaux", "et", "lund")
    for sc in scenes:
        row = f"| {sc} | {_arm_cell('s67_in12', sc)} | {_arm_cell(candidate, sc)} |"
        assert row in history, row
    res = result(judge_file)
    again = load_benchmark("fmg_photo_ab").judge(RESULTS, candidate, "s67_in12", list(scenes),
                                                 [2, 3], rule="flare")
    assert again["decision"] == res["decision"] == "fails (a)"
    assert again["mean"] == pytest.approx(res["mean"])
    return res


def test_exposure_reference_table_is_its_files():
    """docs/history/gnfr.md's sixty-eighth-session table for `--exposure-reference darkest`
    is its arms' files; the judge file is recomputed from them with the verdict and means
    the page quotes; the drawn part's offsets are the round trip's file."""
    history = page_text("docs/history/gnfr.md")

    res = _judged_against_in12(history, "s68_dk", "exposure_reference_judge_s68.json")
    assert not any(res["parts"][p] for p in "abc") and res["parts"]["d"]
    m, ps = res["mean"], res["per_scene"]
    lund = [r["inputs"]["psnr_flare"] for r in _arm_runs("s68_dk", "lund")]
    base = [r["inputs"]["psnr_flare"] for r in _arm_runs("s67_in12", "lund")]
    assert (f"flare region {m['psnr_flare']:+.3f} dB on the mean, lund "
            f"{ps['lund']['psnr_flare']:+.3f} (seed 2 {lund[0] - base[0]:+.2f}, seed 3 "
            f"{lund[1] - base[1]:+.2f}), the whole photo {m['psnr']:+.3f}; the held-out views "
            f"{m['held']:+.3f} on the mean (sceaux {ps['sceaux']['held']:+.3f}, lund "
            f"{ps['lund']['held']:+.3f})") in history
    rt = result("exposure_roundtrip_dk_lund_s68.json")["deflared"]
    means = {k: np.mean([255 * np.mean(r["bias_drawn"]) for r in rt[k]["views"].values()])
             for k in ("in12", "dk")}
    assert len(rt["dk"]["views"]) == 11
    assert (f"{means['dk']:.1f} sRGB levels above the truth on the mean of the 11 views against "
            f"{means['in12']:.1f} at the views' mean exposure") in history


def test_options_quote_the_sixty_eighth_session_judges():
    """docs/options.md's lines on `--source-flare`, `--flare-flag` and
    `--exposure-reference` quote the judge files' means."""
    options = page_text("docs/options.md")
    sf, ff, dk = (result(f"{n}_judge_s68.json")
                  for n in ("source_flare", "flare_flag", "exposure_reference"))
    assert (f"the flare region {sf['mean']['psnr_flare']:+.2f} and "
            f"{ff['mean']['psnr_flare']:+.2f} dB on the development scenes") in options
    assert (f"the flare region {dk['mean']['psnr_flare']:+.3f} dB on the development scenes "
            f"(lund {dk['per_scene']['lund']['psnr_flare']:+.2f})") in options


def test_train_grow_table_is_its_files():
    """docs/history/gnfr.md's sixty-eighth-session table for `--train-grow 0.02` is its arms'
    files; the judge file is recomputed from them with the verdict and means the page and
    docs/options.md quote; the drawn part's offsets are the round trip's file."""
    history = page_text("docs/history/gnfr.md")
    options = page_text("docs/options.md")
    res = _judged_against_in12(history, "s68_gr", "train_grow_judge_s68.json")
    assert [res["parts"][p] for p in "abcd"] == [False, True, False, True]
    m, ps = res["mean"], res["per_scene"]
    assert (f"the flare region {m['psnr_flare']:+.3f} dB on the mean (lund "
            f"{ps['lund']['psnr_flare']:+.3f}, et {ps['et']['psnr_flare']:+.3f}), the whole "
            f"photo {m['psnr']:+.3f}, SSIM {m['ssim']:+.4f}") in history
    assert (f"the flare region moved {m['psnr_flare']:+.3f} dB on the development scenes and "
            f"the whole photo {m['psnr']:+.3f}") in options
    rt = result("exposure_roundtrip_gr_lund_s68.json")["deflared"]
    drawn = {k: {v: 255 * np.mean(r["bias_drawn"]) for v, r in rt[k]["views"].items()}
             for k in ("in12", "gr")}
    means = {k: np.mean(list(v.values())) for k, v in drawn.items()}
    assert (f"{means['gr']:.1f} sRGB levels above the truth on the mean of the 11 views against "
            f"{means['in12']:.1f} (view 02: {drawn['in12']['02']:.1f} to "
            f"{drawn['gr']['02']:.1f})") in history


def test_veil_exploration_numbers_are_its_files():
    """docs/history/gnfr.md's exploration of lund without the veil quotes its arms' files
    (the flare-region gains over `s67_in12`, their mean) and the round trip's offset."""
    history = page_text("docs/history/gnfr.md")
    base, nv = _arm_runs("s67_in12", "lund"), _arm_runs("s68_nv", "lundnv")
    gain = [b["inputs"]["psnr_flare"] - a["inputs"]["psnr_flare"]
            for a, b in zip(base, nv, strict=True)]
    mean = np.mean([b["inputs"]["psnr_flare"] for b in nv])
    assert (f"The flare region gains {gain[0]:+.2f} and {gain[1]:+.2f} dB over `s67_in12` "
            f"({mean:.2f} dB on the mean") in history
    assert f"worth about {np.mean(gain):.1f} dB in lund's flare region" in history
    rt = result("exposure_roundtrip_nv_lund_s68.json")
    assert all(v == 0 for v in rt["flare_outside"].values())  # no veil left outside the masks
    drawn = [255 * np.mean(r["bias_drawn"]) for r in rt["deflared"]["nv"]["views"].values()]
    assert len(drawn) == 11
    assert f"offset falls to {np.mean(drawn):.1f} sRGB levels on the mean of the 11 views" \
        in history


def test_pretrain_exposure_match_outcome_is_its_files():
    """docs/history/gnfr.md's outcome of the sixty-ninth session's rule (pretraining at one
    exposure) is its arms' files: the table's cells, both judge files recomputed from them
    (`--rule flare` and `--rule novel`, both failing at (a)), the means and per-seed ranges
    the page quotes; the card quotes the same means."""
    history = page_text("docs/history/gnfr.md")
    card = page_text("gnfr/weights/gnfr.md")
    scenes = ("sceaux", "et", "lund")
    _assert_arm_rows(history, ('s69_p0', 's69_pe'))
    judge = load_benchmark("fmg_photo_ab").judge
    for rule, name in (("flare", "pretrain_exposure_judge_s69.json"),
                       ("novel", "pretrain_exposure_judge_novel_s69.json")):
        res = result(name)
        again = judge(RESULTS, "s69_pe", "s69_p0", list(scenes), [2, 3], rule=rule)
        assert res["rule"] == rule and again["decision"] == res["decision"] == "fails (a)"
        assert again["mean"] == pytest.approx(res["mean"])
    m, ps = res["mean"], res["per_scene"]
    assert (f"the flare region {m['psnr_flare']:+.3f} dB on the mean (the rule asks +0.10), "
            f"the whole photo {m['psnr']:+.3f}, the held-out views {m['held']:+.3f} (sceaux "
            f"{ps['sceaux']['held']:+.3f}, lund {ps['lund']['held']:+.3f})") in history
    assert (f"+{m['psnr_flare']:.3f} dB in the flare region and their novel views "
            f"{m['held']:+.3f} dB") in card

    flare = _seed_diffs("s69_p0", "s69_pe", "inputs", "psnr_flare")
    held = _seed_diffs("s69_p0", "s69_pe", "heldout", "psnr")
    assert (f"the flare region moves {min(flare):+.2f} to {max(flare):+.2f} dB, the held-out "
            f"views {min(held):+.2f} to {max(held):+.2f}") in history


def test_pretrain_exposure_match_training_psnr_is_its_logs():
    """The two priors' training PSNR over their last 8 000 steps, as docs/history/gnfr.md
    quotes it, is their committed logs' (both runs to step 58 250)."""
    history = page_text("docs/history/gnfr.md")
    psnr = {}
    for arm in ("P0", "PE"):
        rows = [json.loads(x) for x in
                (RESULTS / f"pretrain_exposure_{arm}_s69.jsonl").read_text().splitlines()
                if x.strip()]
        assert rows[-1]["step"] == 58250
        psnr[arm] = np.mean([r["psnr"] for r in rows if r["step"] > 50250])
    assert f"P0 {psnr['P0']:.2f} dB, PE {psnr['PE']:.2f}" in history


def test_veil_estimate_table_is_its_files():
    """The seventy-first session's table of the veil seen by the neighbours (docs/history/
    gnfr.md) is its three files' means over the views with more than 0.5 % marked."""
    history = page_text("docs/history/gnfr.md")
    for scene in ("sceaux", "et", "lund"):
        views = result(f"veil_estimate_{scene}_s71.json")["views"]
        rows = [r for r in views.values() if r["mask_share"] > 0.005 and "smooth_0.05" in r]
        s = [r["smooth_0.05"] for r in rows]
        far = [r["offset_far"] for r in rows if r["offset_far"] is not None]
        row = (f"| {scene} | {len(rows)} | {np.mean([r['veil'] for r in rows]):.2f} | "
               f"{np.mean(far):.2f} | {np.mean([x['psnr_before'] for x in s]):.2f}, "
               f"{np.mean([x['psnr_after'] for x in s]):.2f} | "
               f"{np.mean([x['rms_veil'] for x in s]):.4f}, "
               f"{np.mean([x['rms_error'] for x in s]):.4f} |")
        assert row in history, row
        # the finding the text draws: the estimate's error is several times the veil
        assert np.mean([x["rms_error"] for x in s]) > 2 * np.mean([x["rms_veil"] for x in s])


def test_more_pretraining_outcome_is_its_files():
    """docs/history/gnfr.md's seventy-first-session outcome (the sixty-ninth session's
    control prior P0 against the shipped prior): the table's cells are the arms' files,
    both judge files are recomputed from them (failing), and the quoted means and per-seed
    ranges are theirs."""
    history = page_text("docs/history/gnfr.md")
    scenes = ("sceaux", "et", "lund")
    _assert_arm_rows(history, ('s69_sh', 's69_p0'))
    judge = load_benchmark("fmg_photo_ab").judge
    for rule, name, failed in (("flare", "prior_p0_judge_s71.json", "abc"),
                               ("novel", "prior_p0_judge_novel_s71.json", "ac")):
        res = result(name)
        again = judge(RESULTS, "s69_p0", "s69_sh", list(scenes), [2, 3], rule=rule)
        assert res["rule"] == rule and again["decision"] == res["decision"] == "fails (a)"
        assert again["mean"] == pytest.approx(res["mean"])
        assert {k for k, ok in again["parts"].items() if not ok} == set(failed)
    res = result("prior_p0_judge_s71.json")
    m, lund = res["mean"], res["per_scene"]["lund"]
    assert (f"the flare region {m['psnr_flare']:+.3f} dB on the mean (lund "
            f"{lund['psnr_flare']:+.3f}), the whole photo {m['psnr']:+.3f}, the held-out views "
            f"{m['held']:+.3f}") in history
    flare = _seed_diffs("s69_sh", "s69_p0", "inputs", "psnr_flare")
    held = _seed_diffs("s69_sh", "s69_p0", "heldout", "psnr")
    assert (f"the flare region moves {min(flare):+.2f} to {max(flare):+.2f} dB, the held-out "
            f"views {min(held):+.2f} to {max(held):+.2f}") in history
    for sc in scenes:  # the shipped prior's arms repeat s67_in12's cells
        assert _arm_cell("s69_sh", sc) == _arm_cell("s67_in12", sc)


def test_card_quotes_the_more_pretraining_outcome():
    """gnfr/weights/gnfr.md quotes the seventy-first session's judge of P0 against the shipped
    prior as its file has it."""
    card = page_text("gnfr/weights/gnfr.md")
    res = result("prior_p0_judge_s71.json")
    m, lund = res["mean"], res["per_scene"]["lund"]
    assert (f"{-m['psnr_flare']:.3f} dB in the flare region (lund {-lund['psnr_flare']:.3f}) "
            f"and their novel views {-m['held']:.3f} dB") in card


def test_source_flare_prior_outcome_is_its_files():
    """docs/history/gnfr.md's outcome of the source-flare pretraining (candidate PS): the
    table is the three arms' files, the four judge files are recomputed from them (passing
    `--rule novel` against P0 only), the quoted means are theirs and the training PSNR is
    the committed log's."""
    history = page_text("docs/history/gnfr.md")
    scenes = ("sceaux", "et", "lund")
    _assert_arm_rows(history, ('s69_sh', 's69_p0', 's71_ps'))
    judge = load_benchmark("fmg_photo_ab").judge
    want = {("s69_p0", "flare"): ("source_flare_prior_judge_s71.json", "fails (a)"),
            ("s69_p0", "novel"): ("source_flare_prior_judge_novel_s71.json", "passes"),
            ("s69_sh", "flare"): ("source_flare_prior_vs_shipped_judge_s71.json", "fails (a)"),
            ("s69_sh", "novel"): ("source_flare_prior_vs_shipped_judge_novel_s71.json",
                                  "fails (c)")}
    res = {}
    for (base, rule), (name, decision) in want.items():
        res[base, rule] = result(name)
        again = judge(RESULTS, "s71_ps", base, list(scenes), [2, 3], rule=rule)
        assert again["decision"] == res[base, rule]["decision"] == decision
        assert again["mean"] == pytest.approx(res[base, rule]["mean"])
    m, ps = res["s69_p0", "novel"]["mean"], res["s69_p0", "novel"]["per_scene"]
    assert (f"the held-out views {m['held']:+.3f} dB on the mean, every scene up (sceaux "
            f"{ps['sceaux']['held']:+.3f}, et {ps['et']['held']:+.3f}, lund "
            f"{ps['lund']['held']:+.3f}), the flare region {m['psnr_flare']:+.3f} and the whole "
            f"photo {m['psnr']:+.3f}") in history
    m, ps = res["s69_sh", "novel"]["mean"], res["s69_sh", "novel"]["per_scene"]
    assert (f"gain {m['held']:+.3f} dB on the mean (every scene up) but the flare region loses "
            f"{-m['psnr_flare']:.3f} dB (lund {-ps['lund']['psnr_flare']:.3f})") in history
    assert all(p["held"] > 0 for p in ps.values())
    held = _seed_diffs("s69_p0", "s71_ps", "heldout", "psnr")
    assert f"the held-out views move {min(held):+.2f} to {max(held):+.2f} dB" in history
    rows = [json.loads(x) for x in
            (RESULTS / "pretrain_source_flare_PS_s71.jsonl").read_text().splitlines() if x.strip()]
    assert rows[-1]["step"] == 58250
    late = [r for r in rows if r["step"] > 50250]
    assert (f"over the last 8 000 steps {np.mean([r['psnr'] for r in late]):.2f} dB against "
            f"`P0`'s 20.92, the twins' steps "
            f"{np.mean([r['psnr'] for r in late if 'twin' in r]):.2f}") in history


def test_source_flare_prior4_outcome_is_its_files():
    """docs/history/gnfr.md's outcome of candidate PS4 (the source-flare supervision for 4 000
    steps) is its arms' files and both judges recomputed from them."""
    history = page_text("docs/history/gnfr.md")
    _assert_arm_rows(history, ("s69_sh", "s72_ps4"))
    judge = load_benchmark("fmg_photo_ab").judge
    for rule, name in (("flare", "source_flare_prior4_judge_s71.json"),
                       ("novel", "source_flare_prior4_judge_novel_s71.json")):
        res = result(name)
        again = judge(RESULTS, "s72_ps4", "s69_sh", ["sceaux", "et", "lund"], [2, 3], rule=rule)
        assert again["decision"] == res["decision"]
        assert f"`--rule {rule}` {res['decision']}" in history
        assert again["mean"] == pytest.approx(res["mean"])
    m = result("source_flare_prior4_judge_s71.json")["mean"]
    assert (f"the flare region {m['psnr_flare']:+.3f} dB on the mean, the whole photo "
            f"{m['psnr']:+.3f}, the held-out views {m['held']:+.3f}") in history


def test_goals_page_quotes_the_pretraining_levers_judged():
    """docs/goals.md's paragraph on the `quick` prior's pretraining changes quotes each judge's
    file: the exposure lever's flare region, and P0's, PS's and PS4's flare region and novel
    views against the shipped file's arms."""
    goals = page_text("docs/goals.md")

    def mean(name):
        return result(name)["mean"]

    expo = mean("pretrain_exposure_judge_s69.json")
    assert f"flare region {expo['psnr_flare']:+.3f} dB, under the +0.10 asked" in goals
    p0 = mean("prior_p0_judge_s71.json")
    assert (f"flare region {p0['psnr_flare']:+.3f} dB and novel views {p0['held']:+.3f} "
            "(`prior_p0_judge_s71.json`)") in goals
    ps = mean("source_flare_prior_vs_shipped_judge_s71.json")
    assert (f"novel views {ps['held']:+.3f} dB and flare region {ps['psnr_flare']:+.3f} "
            "(`source_flare_prior_vs_shipped_judge_s71.json`)") in goals
    ps4 = mean("source_flare_prior4_judge_s71.json")
    assert (f"{ps4['held']:+.3f} and {ps4['psnr_flare']:+.3f} "
            "(`source_flare_prior4_judge_s71.json`)") in goals

