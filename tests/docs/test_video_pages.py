"""The video's pages (docs/options.md, docs/history/fill.md, docs/performance.md: the pace of
the camera path, the cross-fades between sources, the path's exposure, the tour by view)
agree with the result files and judgements they quote.

Split from tests/docs/test_fill_pages.py in the ninety-sixth session.
"""

from __future__ import annotations

from pathlib import Path

from tests.docs.numbers import (
    page_text,
    readme_notes,
    result,
    text_rows,
    time_seconds,
)


def _flow_rows(name: str) -> dict:
    """{build: {arm: (90th percentile / median, largest)}} of a path_motion flow file."""
    import numpy as np

    rows: dict = {}
    for folder, rec in result(name)["flow"].items():
        build, arm = Path(folder).name.rsplit("_", 1)
        steps = np.asarray(rec["steps"])
        rows.setdefault(build, {})[arm] = (float(np.percentile(steps, 90) / np.median(steps)),
                                           rec["max"], rec["p95"])
    return rows


def test_video_pace_tables_and_sentences_are_their_files():
    """docs/history/fill.md: the pace rules' numbers (the points' largest steps and spreads on
    the development scenes, the rendered flow there and on the six fresh builds, the means
    and counts the third rule reads) are path_motion_*_s52.json's."""
    import numpy as np

    hist = page_text("docs/history/fill.md")
    label = {"sceaux_synth": "sceaux_castle", "et_synth": "et", "lund_synth": "lund"}
    first = result("path_motion_dev_s52.json")["scenes"]
    points = result("path_motion_dev_points_s52.json")["scenes"]
    for ws, r in first.items():
        name = label[Path(ws).parent.name]
        assert f"{name} {r['travel']['max']:.4f} -> {r['today']['max']:.4f}" in hist
    for ws, r in points.items():
        name = label[Path(ws).parent.name]
        assert f"{r['travel']['max']:.4f} -> {r['today']['max']:.4f} on {name}" in hist or (
            f"{r['travel']['max']:.4f} -> {r['today']['max']:.4f} of the width on {name}"
            in hist)
    for build, r in _flow_rows("path_motion_dev_flow_s52.json").items():
        (_, mx0, p0), (_, mx1, p1) = r["travel"], r["today"]
        assert f"{mx0:.4f} -> {mx1:.4f} on {label[build]}" in hist
        assert f"{p0:.4f} -> {p1:.4f}" in hist
    fresh = _flow_rows("path_motion_fresh_flow_s52.json")
    assert len(fresh) == 6
    for build, r in fresh.items():
        short = build.split("_s50_")[0]
        (s0, mx0, _), (s1, mx1, _) = r["travel"], r["today"]
        assert f"| {short} | {s0:.3f} -> {s1:.3f} | {mx0:.4f} -> {mx1:.4f} |" in hist
    s0 = np.mean([r["travel"][0] for r in fresh.values()])
    s1 = np.mean([r["today"][0] for r in fresh.values()])
    m0 = np.mean([r["travel"][1] for r in fresh.values()])
    m1 = np.mean([r["today"][1] for r in fresh.values()])
    falls = sum(r["today"][0] < r["travel"][0] for r in fresh.values())
    assert (f"| mean | {s0:.3f} -> {s1:.3f} ({100 * (s1 / s0 - 1):+.1f} %) | "
            f"{m0:.4f} -> {m1:.4f} |").replace("+", "") in hist.replace("+", "")
    assert s1 < 0.9 * s0 and falls == 4 and m1 < m0  # the rule's (a), (b), (c)


def test_video_pace_test_scenes_are_their_file():
    """docs/history/fill.md, the README and docs/camera_paths.md: the test scenes' points'
    pace (largest step, largest over median) is path_motion_test_s52.json's."""
    scenes = result("path_motion_test_s52.json")["scenes"]
    hist = page_text("docs/history/fill.md")
    notes = readme_notes()
    label = {"cyprus.deflare": "the sample (cyprus)", "kermit_bf16": "kermit",
             "fern_ws": "fern"}
    for ws, r in scenes.items():
        p = Path(ws)
        name = label[p.name if p.name == "cyprus.deflare" else p.parent.name]
        t, n = r["travel"], r["today"]
        assert f"{name} {t['max']:.4f} -> {n['max']:.4f}" in hist
        assert f"{t['max_over_median']:.2f} -> {n['max_over_median']:.2f}" in hist
        if name.startswith("the sample"):
            assert f"{t['max']:.3f} of the width before, {n['max']:.3f} now" in notes
            # its pace a second at the CPU's 12 fps and 4 s, as the README and paths page say
            pct = f"{100 * n['median'] * 12:.0f} %"
            paths = page_text("docs/camera_paths.md")
            options = page_text("docs/options.md")  # its "At a glance" table
            assert f"(the sample: {pct} of the frame's width a second" in options
            assert f"4-second tour moves {pct} a second at 12 fps" in paths


def test_video_pace_sample_flow_and_cost_are_their_files():
    """The sample's video before and after the pace (its frames' flow) in the history and
    README, and docs/performance.md's one-shot pair and render times, are the files'."""
    flow = result("path_motion_sample_flow_s52.json")["flow"]
    (old,) = [v for k, v in flow.items() if "fresh51o" in k]
    (new,) = [v for k, v in flow.items() if "s52head" in k]
    hist = page_text("docs/history/fill.md")
    notes = readme_notes()
    perf = page_text("docs/performance.md")
    assert f"step {old['max']:.4f} -> {new['max']:.4f} of the width" in hist
    assert f"{old['max_over_median']:.2f} -> {new['max_over_median']:.2f}" in hist
    assert f"optical flow {old['max']:.3f} and {new['max']:.3f}" in notes
    _oneshot_pair(perf, ("sample_oneshot_cpu_s52_head.json", "b4f97db"),
                  ("sample_oneshot_cpu_s52_49b4096.json", "49b4096"))
    times = text_rows("path_pace_render_times_s52.txt")
    secs = {i: float(t[-2]) for i, t in enumerate(times)}
    assert (f"took {secs[2]:.1f} s (49b4096) and {secs[3]:.1f} s (b4f97db)") in perf
    assert (f"{secs[0]:.1f} s (old) against {secs[1]:.1f} s (new), then {secs[4]:.1f} s "
            f"(new) against {secs[5]:.1f} s (old)") in perf


def _oneshot_pair(perf: str, head: tuple[str, str], base: tuple[str, str]) -> None:
    """Two one-shot score files (name, commit) that docs/performance.md (``perf``, its
    words joined by single spaces) compares: each from its commit, their frames' and
    fine-tune's seconds quoted, their de-flared photos the same to the last digit and
    their scores quoted."""
    recs = []
    for name, commit in (head, base):
        rec = result(name)
        assert rec["code"]["commit"].startswith(commit), name
        recs.append(rec)
    st = [(r["stages"]["render:interpolate"]["seconds"], r["stages"]["finetune"]["seconds"])
          for r in recs]
    assert (f"the 48 frames {st[0][0]:.1f} s against {st[1][0]:.1f} s, the fine-tune "
            f"{st[0][1]:.1f} s against {st[1][1]:.1f} s") in perf
    assert recs[0]["mean"] == recs[1]["mean"]  # the de-flared photos to the last digit
    m = recs[0]["mean"]
    assert f"({m['psnr_flare']:.2f} / {m['psnr']:.2f} dB)" in perf


def test_the_whip_pan_the_pace_rule_quotes_is_the_old_paths():
    """The first pace rule's whip-pan (14 degrees a frame, the frames between turning 1-5
    degrees) is the turn between consecutive cameras of the sample's old path."""
    import numpy as np

    frames = result("sample_path_cameras_49b4096.json")["frames"]
    R = np.array([np.asarray(f["c2w"])[:3, :3] for f in frames])
    cos = (np.trace(np.swapaxes(R[:-1], 1, 2) @ R[1:], axis1=1, axis2=2) - 1) / 2
    turn = np.degrees(np.arccos(np.clip(cos, -1, 1)))
    hist = page_text("docs/history/fill.md")
    assert f"whip-pan of {turn.max():.0f} degrees a frame at 12 fps" in hist
    assert 1 <= np.median(turn) <= 5 and "frames between them turn 1-5 degrees" in hist


def _render_option_pages() -> tuple[str, str, str]:
    """(docs/history/fill.md, docs/options.md, pipeline/render/config.py): the pages a render
    option's judgement is quoted on (its history, its line in options.md, its docstring)."""
    return (page_text("docs/history/fill.md"), page_text("docs/options.md"),
            page_text("pipeline/render/config.py"))


def _judge_rows(name: str) -> tuple[dict, dict]:
    """(the judge file ``name`` of benchmarks/video_flicker.py --judge, {build's short name:
    its table cells "largest | mean | sharpness", each "before -> after"})."""
    rec = result(name)
    cells = {Path(cand).name.split("_s50_")[0]: " | ".join(
        f"{r[k][0]:.4f} -> {r[k][1]:.4f}" for k in ("largest", "mean", "sharpness"))
        for cand, r in rec["builds"].items()}
    return rec, cells


def test_source_fade_rule_is_its_files():
    """docs/history/fill.md's table of the cross-fade's rule, its means and verdicts, and the
    numbers the README, docs/options.md and the option's docstring quote are the judge
    files' (fade_judge_fade{1,2}_s53.json), and the verdicts follow the rule."""
    hist, options, config = _render_option_pages()
    one, cells = _judge_rows("fade_judge_fade1_s53.json")
    two = result("fade_judge_fade2_s53.json")
    for r, (short, row) in zip(one["builds"].values(), cells.items(), strict=True):
        assert f"| {short} | {row} | {r['renders_per_frame'][1]:.2f} |" in hist, short
        assert r["unfaded_identical"] == r["unfaded_frames"]
    rel1, rel2 = one["relative"], two["relative"]
    assert one["passes"] and not two["passes"] and not two["checks"]["c"]
    assert (f"(a) largest step {100 * rel1['largest']:.1f} %, lower on five builds" in hist
            and one["largest_down_on"] == 5)
    assert (f"(b) mean {100 * rel1['mean']:.1f} %; (c) sharpness "
            f"{100 * rel1['sharpness']:.2f} %") in hist
    assert f"(d) {one['renders_per_frame']:.2f} images a frame" in hist
    assert f"largest step {100 * rel2['largest']:.1f} %" in hist
    assert f"sharpness {100 * rel2['sharpness']:.1f} %" in hist
    for page in (options,):  # its prose and its "At a glance" table
        assert f"{-100 * rel2['largest']:.1f} %" in page
        assert f"{-100 * rel1['largest']:.1f} %" in page
        assert f"{-100 * rel2['sharpness']:.1f} %" in page
    assert f"{-100 * rel1['sharpness']:.1f} %" in options
    assert f"-{-100 * rel1['largest']:.0f} % on the mean of six" in config
    assert f"{one['renders_per_frame']:.2f} images a frame" in config


def _step_phrase(name: str, third: str = "sharpness") -> tuple[dict, dict, str]:
    """(the one build's row, the relative changes, the phrase "the largest step A -> B (x %),
    the steps' mean C -> D (y %), THIRD z %") of a one-build judge file of
    benchmarks/video_flicker.py --judge."""
    rec = result(name)
    (r,) = rec["builds"].values()
    rel = rec["relative"]
    return r, rel, (f"the largest step {r['largest'][0]:.4f} -> {r['largest'][1]:.4f} "
                    f"({100 * rel['largest']:+.1f} %), the steps' mean {r['mean'][0]:.4f} -> "
                    f"{r['mean'][1]:.4f} ({100 * rel['mean']:+.1f} %), {third} "
                    f"{100 * rel[third]:+.1f} %")


def test_source_fade_on_the_sample_is_its_file():
    """The sample's video with and without the cross-fade (README, docs/history/fill.md) is
    fade_sample_s53.json's."""
    hist = page_text("docs/history/fill.md")
    notes = readme_notes()
    r, rel, phrase = _step_phrase("fade_sample_s53.json")
    assert r["unfaded_identical"] == r["unfaded_frames"] == 42
    assert phrase in hist
    assert f"{r['renders_per_frame'][1]:.3f} images a frame" in hist
    assert (f"largest jump between frames {-100 * rel['largest']:.1f} % lower, the steps' "
            f"mean {100 * rel['mean']:.1f} % higher") in notes


def test_source_hold_rule_is_its_files():
    """docs/history/fill.md's table of the hold's rule, its means and verdicts, and the
    numbers docs/options.md and the option's docstring quote are the judge files'
    (hold_judge_hold{1,2}_s53.json); both fail (c), as the history says."""
    hist, options, config = _render_option_pages()
    one, cells = _judge_rows("hold_judge_hold1_s53.json")
    two = result("hold_judge_hold2_s53.json")
    for r, (short, row) in zip(one["builds"].values(), cells.items(), strict=True):
        rpf = r["renders_per_frame"]
        assert f"| {short} | {row} | {rpf[0]:.2f} -> {rpf[1]:.2f} |" in hist, short
    r1, r2 = one["relative"], two["relative"]
    assert not one["passes"] and not one["checks"]["c"] and one["checks"]["a"]
    assert not two["passes"] and not two["checks"]["a"] and not two["checks"]["c"]
    assert (f"(a) the mean {100 * r1['mean']:.2f} %, (b) the largest step "
            f"{100 * r1['largest']:.2f} %, (c) sharpness {100 * r1['sharpness']:.2f} %, (d) "
            f"{one['renders_per_frame']:.2f} images a frame against "
            f"{one['baseline_renders_per_frame']:.2f}") in hist
    assert (f"mean {100 * r2['mean']:.2f} %, largest step +{100 * r2['largest']:.2f} %, "
            f"sharpness {100 * r2['sharpness']:.2f} %, {two['renders_per_frame']:.2f} images "
            "a frame") in hist
    for page in (options, config):
        assert (f"{one['renders_per_frame']:.2f} images a frame instead of "
                f"{one['baseline_renders_per_frame']:.2f}") in page
        assert f"-{-100 * r1['mean']:.1f} % on six" in page
        assert f"{-100 * r1['sharpness']:.2f} % less sharp" in page


def test_the_cross_fades_cost_is_its_files():
    """docs/performance.md, "The cross-fade's cost": the one-shots' stage times and scores
    (sample_oneshot_cpu_s53_{head,c9a6309}.json), the four renders in turn
    (fade_sample_times_s53.txt) and the head video's share of faded frames."""
    perf = page_text("docs/performance.md")
    _oneshot_pair(perf, ("sample_oneshot_cpu_s53_head.json", "25c4eb2"),
                  ("sample_oneshot_cpu_s53_c9a6309.json", "c9a6309"))
    rows = text_rows("fade_sample_times_s53.txt")
    secs = {r[0]: float(r[-2]) for r in rows}
    assert [r[1] for r in rows] == ["source_fade=0", "source_fade=1", "source_fade=1",
                                    "source_fade=0"]
    off, on = (secs["f0a"] + secs["f0b"]) / 2, (secs["f1a"] + secs["f1b"]) / 2
    assert (f"{secs['f0a']:.1f} and {secs['f0b']:.1f} s without the fade, "
            f"{secs['f1a']:.1f} and {secs['f1b']:.1f} s with it, {off:.1f} against "
            f"{on:.1f} s on the mean (+{100 * (on / off - 1):.0f} %") in perf
    sample = result("fade_sample_s53.json")
    (r,) = sample["builds"].values()
    faded = 48 - r["unfaded_frames"]
    assert f"on the sample {faded} of 48 frames, {r['renders_per_frame'][1]:.3f} images" in perf


def test_the_street_walks_pace_with_the_fade_is_its_file():
    """docs/history/fill.md, "The street walk's pace with the fade": the flow's spread of
    both lund builds, travel -> image pace, is path_motion_lund_fade_s53.json's, and the
    image pace is the less even on both."""
    hist = page_text("docs/history/fill.md")
    rows = _flow_rows("path_motion_lund_fade_s53.json")
    assert len(rows) == 2
    for build, r in rows.items():
        travel, image = r["travelfade"][0], r["fade1"][0]
        assert f"{build.split('_s50_')[0]} {travel:.3f} -> {image:.3f}" in hist
        assert image > travel


def test_source_fade_on_kermit_is_its_file():
    """The test scene kermit with and without the cross-fade (docs/history/fill.md, the
    README) is fade_kermit_s53.json's."""
    hist = page_text("docs/history/fill.md")
    notes = readme_notes()
    r, rel, phrase = _step_phrase("fade_kermit_s53.json")
    assert r["unfaded_identical"] == r["unfaded_frames"] == 48 - 15
    assert phrase in hist
    assert f"({r['renders_per_frame'][1]:.3f} images a frame)" in hist
    assert (f"kermit the largest jump {100 * rel['largest']:.1f} % higher, the mean "
            f"{-100 * rel['mean']:.1f} % lower") in notes


def test_fade_blends_exploration_is_its_files():
    """docs/history/fill.md, "The cross-fade's renders aligned before they are mixed": each
    build's row (steps' mean, largest step, sharpness by DIS, relative to the plain mean) is
    fade_blend_parts_BUILD_s54.json's, and neither blend moves the mean by 1 %."""
    hist = page_text("docs/history/fill.md")

    def pct(x: float) -> str:
        return f"{100 * x:+.2f} %".replace("+0.00", "0.00").replace("-0.00", "0.00")

    for build in ("sceaux_p4", "et_p5", "lund_k4"):
        rec = result(f"fade_blend_parts_{build}_s54.json")["blends"]
        cells = [" / ".join(pct(rec[b]["dis"][f"{k}_rel"]) for k in ("mean", "max", "sharpness"))
                 for b in ("align", "morph", "nofade")]
        assert f"| {build} | {' | '.join(cells)} |" in hist, build
        for b in ("align", "morph"):
            assert all(abs(rec[b][fl]["mean_rel"]) < 0.01 for fl in ("dis", "farneback"))


def _loo_pairs(name: str) -> dict:
    """{build's short name: (PSNR before, after, SSIM before, after)} of a loo_pairs file."""
    rec = result(name)
    return rec, {Path(c).name.split("_s50_")[0]: (*r["psnr"], *r["ssim"])
                 for c, r in rec["pairs"].items()}


def test_path_exposure_first_rule_is_its_file():
    """docs/history/fill.md's left-out table of the path exposure's first rule and its mean
    are exposure_loo_pe1_s54.json's; it fails (d), every build's PSNR down."""
    hist = page_text("docs/history/fill.md")
    rec, rows = _loo_pairs("exposure_loo_pe1_s54.json")
    for short, (p0, p1, s0, s1) in rows.items():
        assert f"| {short} | {p0:.3f} -> {p1:.3f} | {s0:.4f} -> {s1:.4f} |" in hist, short
        assert p1 < p0 and s1 > s0
    m = rec["mean"]
    assert m["psnr"] < -0.05
    assert (f"PSNR {m['psnr']:.3f} dB on the mean (every build down), SSIM "
            f"+{m['ssim']:.4f} (every build up)") in hist


def test_path_exposure_rule_is_its_files():
    """docs/history/fill.md's tables of the path exposure's second rule (the videos and the
    left-out views), its means and the numbers the README, docs/options.md and the option's
    docstring quote are exposure_judge_pe1n_s54.json's and exposure_loo_pe1n_s54.json's;
    the verdict follows the rule, and the option's default is 1."""
    from pipeline.render.config import RenderConfig

    hist, options, config = _render_option_pages()
    notes = readme_notes()
    judge = result("exposure_judge_pe1n_s54.json")
    for cand, r in judge["builds"].items():
        short = Path(cand).name.split("_s50_")[0]
        cells = [f"{r[k][0]:.4f} -> {r[k][1]:.4f}" for k in ("largest", "mean", "mean_farneback")]
        cells += [f"{r['brightness'][0]:.3f} -> {r['brightness'][1]:.3f}",
                  f"{r['matched_sharpness'][0]:.4f} -> {r['matched_sharpness'][1]:.4f}"]
        assert f"| {short} | {' | '.join(cells)} |" in hist, short
    rel = judge["relative"]
    assert judge["passes"] and judge["rule"]["mean"] == -0.02
    assert (f"(a) the steps' mean error {100 * rel['mean']:.2f} % by DIS and "
            f"{100 * rel['mean_farneback']:.2f} % by Farneback; (b) the largest step "
            f"{100 * rel['largest']:.2f} % (lower on {judge['largest_down_on']} builds); (c) the "
            f"brightness {100 * rel['brightness']:.2f} %") in hist
    loo, rows = _loo_pairs("exposure_loo_pe1n_s54.json")
    for short, (p0, p1, s0, s1) in rows.items():
        assert f"| {short} | {p0:.3f} -> {p1:.3f} | {s0:.4f} -> {s1:.4f} |" in hist, short
        assert p1 >= p0 and s1 >= s0
    m = loo["mean"]
    assert m["psnr"] >= -0.05 and m["ssim"] >= -0.002  # (d)
    assert f"(d) PSNR +{m['psnr']:.3f} dB, SSIM +{m['ssim']:.4f} on the mean, no build down" in hist
    for page in (notes, options, config):
        assert f"{100 * rel['mean']:.1f} %" in page and f"{100 * rel['largest']:.1f} %" in page
        assert f"+{m['psnr']:.2f} dB" in page
    assert (f"{100 * rel['mean_farneback']:.1f} % by a second flow" in options
            and f"+{m['ssim']:.4f} SSIM" in options)
    assert RenderConfig().path_exposure == 1.0


def test_path_exposure_pilot_and_spread_are_their_files():
    """The exposure spread of the six builds and the pilot on a seventh that
    docs/history/fill.md quotes are exposure_spread_dev_s54.json's and
    exposure_pilot_lund_s23_s54.json's."""
    hist = page_text("docs/history/fill.md")
    builds = result("exposure_spread_dev_s54.json")["builds"]
    ev = [b["spread_ev"] for b in builds.values()]
    assert f"differ in exposure by {min(ev):.2f} to {max(ev):.2f} EV" in hist
    lo = min(b["gain_min"] for b in builds.values())
    hi = max(b["gain_max"] for b in builds.values())
    assert f"the model's gains from {lo:.2f} to {hi:.2f}" in hist
    rel = result("exposure_pilot_lund_s23_s54.json")["relative"]
    assert (f"the steps' mean error {100 * rel['mean']:.1f} % by DIS, "
            f"{100 * rel['mean_farneback']:.1f} % by Farneback, the largest step "
            f"{100 * rel['largest']:.1f} %, the brightness {100 * rel['brightness']:.1f} %") in hist
    assert (f"mean Sobel gradient fell {-100 * rel['sharpness']:.1f} % "
            f"({-100 * rel['matched_sharpness']:.1f} % at the baseline's exposure)") in hist


def test_path_exposure_on_the_test_scenes_is_its_files():
    """The test scenes' videos and left-out views with and without the path exposure
    (docs/history/fill.md, the README) and their exposure spread are exposure_kermit_s54,
    exposure_sample_s54, exposure_loo_test_s54 and exposure_spread_test_s54's."""
    hist = page_text("docs/history/fill.md")
    notes = readme_notes()
    for name, label in (("kermit", "kermit"), ("sample", "the sample")):
        _, rel, phrase = _step_phrase(f"exposure_{name}_s54.json", "brightness")
        assert f"{label} {phrase}" in hist, name
        assert abs(rel["mean"]) < 0.01
    k = result("exposure_kermit_s54.json")["relative"]
    s = result("exposure_sample_s54.json")["relative"]
    assert (f"kermit's largest jump {100 * k['largest']:.1f} %, the sample's "
            f"{100 * s['largest']:.1f} %") in notes
    loo = result("exposure_loo_test_s54.json")["pairs"]
    (lk, lc) = loo.values()
    assert (f"kermit PSNR {lk['psnr'][0]:.3f} -> {lk['psnr'][1]:.3f}, SSIM {lk['ssim'][0]:.4f} "
            f"-> {lk['ssim'][1]:.4f}; cyprus PSNR {lc['psnr'][0]:.3f} -> {lc['psnr'][1]:.3f}, "
            f"SSIM {lc['ssim'][0]:.4f} -> {lc['ssim'][1]:.4f}") in hist
    spread = result("exposure_spread_test_s54.json")["builds"]
    ev = f"{spread['kermit']['spread_ev']:.2f} and {spread['sample']['spread_ev']:.2f} EV"
    assert ev in notes
    assert (f"span {spread['kermit']['spread_ev']:.2f} EV on kermit and "
            f"{spread['sample']['spread_ev']:.2f} EV on the sample") in hist


def test_the_path_exposures_cost_is_its_file():
    """docs/performance.md, "The exposure along the path's cost", is
    exposure_sample_times_s54.txt's: the four renders in turn and the conversion per
    photo, and the conversion's bound over the sample's images."""
    perf = page_text("docs/performance.md")
    rows = text_rows("exposure_sample_times_s54.txt")
    secs = {r[0]: float(r[-2]) for r in rows if r[0] != "between"}
    ms = float(rows[-1][-2])
    assert [r[1] for r in rows[:4]] == ["path_exposure=0", "path_exposure=1",
                                        "path_exposure=1", "path_exposure=0"]
    assert f"{ms:.2f} ms at the sample's size" in perf
    images = 54  # 48 frames, 1.125 images a frame (fade_sample_s53.json)
    assert f"at most about {6 * images * ms / 1000:.1f} s over the sample's {images} images" in perf
    assert (f"{secs['p0a']:.2f} and {secs['p0b']:.2f} s without, {secs['p1a']:.2f} and "
            f"{secs['p1b']:.2f} s with it") in perf
    spread = max(secs.values()) - min(secs.values())
    assert f"the spread between runs ({spread:.0f} s)" in perf


def test_fade_cut_rule_is_its_files():
    """docs/history/fill.md, "The cross-fade's cut by the path's own steps": the table and
    the rule's four parts are fade_cut_judge_s55.json's, the frames planned alike identical
    (fade_cut_plans_s55.json), and the option stays off by default because (c) failed."""
    from pipeline.render import RenderConfig

    hist = page_text("docs/history/fill.md")
    rec = result("fade_cut_judge_s55.json")
    plans = result("fade_cut_plans_s55.json")["paths"]
    assert rec["rule_name"] == "cut" and rec["identical"]
    rendered = [plans[k] for k in ("tumbler12", "maryrose12", "tumbler24", "maryrose24")]
    assert all(p["alike_but_different"] == [] for p in rendered)
    names = {"tumbler12": "tumbler, 48 frames", "maryrose12": "maryrose, 48 frames",
             "tumbler24": "tumbler, 96 frames", "maryrose24": "maryrose, 96 frames"}
    for cand, r in rec["builds"].items():
        key = Path(cand).name.removesuffix("_cut3")
        lg, mn, sh, ipf = r["largest"], r["mean"], r["sharpness"], r["renders_per_frame"]
        sf = ".5f" if sh[0] < 0.01 else ".4f"
        assert (f"| {names[key]} | {lg[0]:.4f} -> {lg[1]:.4f} | {mn[0]:.4f} -> {mn[1]:.4f} | "
                f"{sh[0]:{sf}} -> {sh[1]:{sf}} | {ipf[0]:.2f} -> {ipf[1]:.2f} |") in hist
        assert (round(ipf[0], 4), round(ipf[1], 4)) == (plans[key]["images_per_frame_cut0"],
                                                         plans[key]["images_per_frame_cut3"])
    rel, checks = rec["relative"], rec["checks"]
    assert checks == {"a": True, "b": True, "c": False, "d": True} and not rec["passes"]
    assert (f"(a) the steps' mean error {100 * rel['mean']:.2f} %, down on all four paths"
            in hist and all(r["mean"][1] < r["mean"][0] for r in rec["builds"].values()))
    assert f"(b) the largest step {100 * rel['largest']:.1f} %" in hist
    assert f"(c) the sharpness {100 * rel['sharpness']:.2f} %" in hist
    ratio = rec["renders_per_frame"] / rec["baseline_renders_per_frame"]
    assert (f"(d) {rec['renders_per_frame']:.2f} images a frame against "
            f"{rec['baseline_renders_per_frame']:.2f}, {ratio:.2f} times") in hist
    assert RenderConfig().fade_cut == 0.0
    times = time_seconds("fade_cut_times_s55.txt")
    for key, label in names.items():
        t0, t3 = (round(times[f"{key}_cut{c}"]) for c in (0, 3))
        assert f"| {t0} s -> {t3} s |" in hist, label
    t12, t24 = plans["tumbler12"], plans["tumbler24"]
    assert (f"steps {t12['step_spacings_median']:.2f} spacings at its median, "
            f"{t12['step_spacings_max']:.2f} at most") in hist
    assert (f"({t12['faded_frames_cut0']} of 48 frames faded; {t12['faded_frames_cut3']} when "
            "none of its steps is a cut)") in hist
    assert (f"steps {t24['step_spacings_median']:.2f} at its median and "
            f"{t24['step_spacings_max']:.2f} at most") in hist
    assert (f"tumbler {t24['faded_frames_cut0']} of 96 frames, maryrose "
            f"{plans['maryrose24']['faded_frames_cut0']})") in hist
    builds = [p for k, p in plans.items() if "_s50_" in k]
    assert len(builds) == 6 and all(p["planned_alike"] == p["frames"] for p in builds)
    meds = sorted(p["step_spacings_median"] for p in builds)
    assert f"{meds[0]:.2f} to {meds[-1]:.2f} spacings at their median" in hist
    assert max(p["step_spacings_max"] for p in builds) < 1.0


def test_fade_on_dense_objects_is_its_files():
    """docs/history/fill.md, "What the cross-fade costs on a densely photographed object":
    the table is dense_fade_{tumbler24,maryrose24}_s55.json's and the two times files', and
    the README's troubleshooting row quotes maryrose's numbers."""
    hist = page_text("docs/history/fill.md")
    options = page_text("docs/options.md")
    times = time_seconds("dense_fade_times_s55.txt", "fade_cut_times_s55.txt")
    for scene in ("tumbler", "maryrose"):
        rec = result(f"dense_fade_{scene}24_s55.json")
        (r,) = rec["builds"].values()
        assert r["unfaded_identical"] == r["unfaded_frames"] and Path(r["baseline"]).name == (
            f"{scene}24_fade0")
        lg, mn, sh, ipf = r["largest"], r["mean"], r["sharpness"], r["renders_per_frame"]
        sf = ".5f" if sh[0] < 0.01 else ".4f"
        t0, t1 = (round(times[f"{scene}24_{a}"]) for a in ("fade0", "cut0"))
        assert (f"| {scene}, 96 frames | {lg[0]:.4f} -> {lg[1]:.4f} | {mn[0]:.4f} -> "
                f"{mn[1]:.4f} | {sh[0]:{sf}} -> {sh[1]:{sf}} | {ipf[0]:.2f} -> {ipf[1]:.2f} | "
                f"{t0} s -> {t1} s |") in hist
        rel = rec["relative"]
        if scene == "tumbler":
            assert lg[0] == lg[1]
            assert (f"({100 * rel['mean']:.1f} % on the steps' mean, {100 * rel['sharpness']:.1f}"
                    " % sharpness)") in hist
        else:
            ratio = times["maryrose24_cut0"] / times["maryrose24_fade0"]
            phrase = (f"falls {-100 * rel['largest']:.0f} % but its frames lose "
                      f"{-100 * rel['sharpness']:.1f} % of their sharpness and take {ratio:.1f} "
                      "times as long")
            assert phrase in hist
            assert (f"{ipf[1]:.1f} images a frame, the frames {-100 * rel['sharpness']:.1f} % "
                    f"less sharp for a largest jump {-100 * rel['largest']:.0f} % lower, "
                    f"{ratio:.1f} times the time)") in options


def test_fade_limit_rule_is_its_files():
    """docs/history/fill.md, "The cross-fade stepping back on a dense path": the fade judged
    against none on the two spiral paths is fade_limit_judge_s55.json's, the plans'
    images a frame are fade_limit_plans_s55.json's (the development and test videos under
    the limit, so unchanged), and the step-back is the default."""
    from pipeline.render import RenderConfig

    hist = page_text("docs/history/fill.md")
    options = page_text("docs/options.md")
    rec = result("fade_limit_judge_s55.json")
    plans = result("fade_limit_plans_s55.json")["paths"]
    times = time_seconds("fade_limit_times_s55.txt")
    assert rec["rule_name"] == "fade" and rec["identical"] and not rec["passes"]
    assert not (rec["checks"]["a"] and rec["checks"]["c"])
    for cand, r in rec["builds"].items():
        scene = Path(cand).name.removesuffix("sp_fade1")
        assert Path(r["baseline"]).name == f"{scene}sp_fade0"
        lg, mn, sh, ipf = r["largest"], r["mean"], r["sharpness"], r["renders_per_frame"]
        assert round(ipf[1], 4) == plans[f"{scene}_spiral"]["images_per_frame"] > 1.5
        sf = ".5f" if sh[0] < 0.01 else ".4f"
        t0, t1 = (round(times[f"{scene}sp_fade{f}"]) for f in (0, 1))
        assert (f"| {scene}, spiral | {lg[0]:.4f} -> {lg[1]:.4f} | {mn[0]:.4f} -> {mn[1]:.4f} | "
                f"{sh[0]:{sf}} -> {sh[1]:{sf}} | {ipf[0]:.2f} -> {ipf[1]:.2f} | {t0} s -> "
                f"{t1} s |") in hist
    rel = rec["relative"]
    assert (f"the largest step {100 * rel['largest']:+.1f} % on the mean, down on "
            f"{rec['largest_down_on']} of the two paths") in hist
    assert (f"the steps' mean {100 * rel['mean']:+.1f} %, the sharpness "
            f"{100 * rel['sharpness']:+.1f} %") in hist
    others = {k: p for k, p in plans.items() if not k.endswith("_spiral")}
    assert len(others) == 8 and all(p["images_per_frame"] <= 1.5 for p in others.values())
    dev = sorted(p["images_per_frame"] for k, p in others.items() if "_s50_" in k)
    assert f"{dev[0]:.2f} to {dev[-1]:.2f} images a frame" in hist
    assert (f"the sample {others['sample']['images_per_frame']:.2f}, kermit "
            f"{others['kermit']['images_per_frame']:.2f}") in hist
    assert RenderConfig().fade_limit == 1.5
    assert "2.6 images a frame, the largest jump -21 %, the frames 4.8 % less sharp" in options


def test_source_fade_on_a_close_object_is_its_file():
    """docs/history/fill.md, "The cross-fade on a close object": tumbler's video with and
    without the fade is fade_tumbler_s54.json's, its largest step untouched."""
    hist = page_text("docs/history/fill.md")
    rec = result("fade_tumbler_s54.json")
    (r,) = rec["builds"].values()
    rel = rec["relative"]
    assert r["unfaded_identical"] == r["unfaded_frames"] and r["largest"][0] == r["largest"][1]
    assert (f"{48 - r['unfaded_frames']} of 48 frames faded ({r['renders_per_frame'][1]:.3f} "
            f"images a frame), the steps' mean {r['mean'][0]:.4f} -> {r['mean'][1]:.4f} "
            f"({100 * rel['mean']:.1f} %), sharpness {100 * rel['sharpness']:.1f} %") in hist
    assert f"the largest step {r['largest'][0]:.4f} -> {r['largest'][1]:.4f}: untouched" in hist


def test_tour_by_view_rule_is_its_file():
    """docs/history/fill.md, "The interpolate path's tour by travel and turn": each
    development scene's total and largest step, today -> view, are tour_view_dev_s56.json's,
    the rule's three parts are read from them (all fail), and the tour stays by position."""
    from pipeline.render import RenderConfig

    hist = page_text("docs/history/fill.md")
    options = page_text("docs/options.md")
    scenes = result("tour_view_dev_s56.json")["scenes"]
    label = {"et_ws": "et", "sceaux_ws": "sceaux_castle", "lund_ws": "lund",
             "maryrose_ws": "maryrose", "tumbler_ws": "tumbler"}
    ratios, rises = [], []
    for ws, r in scenes.items():
        t, v = r["today"], r["view"]
        name = label[Path(ws).name]
        if t["steps"] == v["steps"]:
            row = (f"| {name} | {t['total']:.3f} -> {v['total']:.3f}, the same tour | "
                   f"{t['max']:.4f} -> {v['max']:.4f} |")
        else:
            row = (f"| {name} | {t['total']:.3f} -> {v['total']:.3f} "
                   f"({100 * (v['total'] / t['total'] - 1):+.1f} %) | {t['max']:.4f} -> "
                   f"{v['max']:.4f} ({100 * (v['max'] / t['max'] - 1):+.1f} %) |")
        assert row in hist
        ratios.append(v["total"] / t["total"])
        rises.append((v["total"] / t["total"] - 1, v["max"] / t["max"] - 1))
    assert len(ratios) == 5
    mean = sum(ratios) / len(ratios) - 1
    assert f"(a) the mean of the ratios {100 * mean:+.1f} % where -5 % was asked: fails" in hist
    assert mean > -0.05  # (a) fails
    assert max(r[0] for r in rises) > 0.02 and max(r[1] for r in rises) > 0.05  # (b), (c)
    maryrose = next(r for ws, r in scenes.items() if "maryrose" in ws)
    fall = 1 - maryrose["view"]["total"] / maryrose["today"]["total"]
    assert f"on maryrose the video moves {100 * fall:.0f} % less" in options
    assert RenderConfig().tour == "position"
    test = result("tour_view_test_s56.json")["scenes"]
    names = {"cyprus.deflare": "the sample", "kermit_ws": "kermit", "fern_ws": "fern"}
    for ws, r in test.items():
        t, v = r["today"]["total"], r["view"]["total"]
        assert (f"{names[Path(ws).name]} {t:.3f} -> {v:.3f} ({100 * (v / t - 1):+.1f} %)"
                in hist)


def test_zoom_rule_is_its_file():
    """docs/history/fill.md, docs/camera_paths.md and docs/options.md, the interpolate path's
    zoom: every
    photo's zoom and PSNR pair, the means, the verdict and the paths' steps are
    path_zoom_sacre_coeur_s98.json's; the rule's verdict is recomputed from its rows, and
    the default follows it."""
    import numpy as np

    from pipeline.render import RenderConfig
    from tests.conftest import load_benchmark

    hist = page_text("docs/history/fill.md")
    paths_page = page_text("docs/camera_paths.md")
    rec = result("path_zoom_sacre_coeur_s98.json")
    rows, verdict = rec["photos"], rec["judge"]
    again = load_benchmark("path_zoom").judge(rows, rec["min_zoom"])
    assert again == verdict and verdict["passed"]
    assert RenderConfig().zoom == "photos"
    zoomed = [r for r in rows if r["zoom"] >= rec["min_zoom"]]
    for r in zoomed:
        assert (f"{r['zoom']:.2f}, {r['fixed']['psnr']:.2f} -> {r['photos']['psnr']:.2f}"
                in hist.replace("1.63 times, ", "1.63, "))
    gain, rise = verdict["zoomed_mean_gain_db"], -verdict["others_mean_fall_db"]
    words = {2: "two", 3: "three", 4: "four", 5: "five", 6: "six"}
    for page in (hist, paths_page):
        assert f"the {words[len(zoomed)]} zoomed-in photos {gain:.2f} dB higher" in page
        assert f"the {words[len(rows) - len(zoomed)]} others {rise:.2f} dB higher" in page
    assert (f"{gain:.2f} dB lower on the {words[len(zoomed)]} zoomed-in photos' mean"
            in page_text("docs/options.md"))
    ref = next(r for r in rows if r["zoom"] == 1.0)
    assert f"the reference itself the same, {ref['photos']['psnr']:.2f} dB" in hist
    assert ref["photos"] == ref["fixed"]
    steps = rec["path_steps"]
    pct = {a: (100 * steps[a]["median_step"], 100 * steps[a]["largest_step"]) for a in steps}
    assert (f"the median step moves the scene {pct['photos'][0]:.3f} % of the width and the "
            f"largest {pct['photos'][1]:.3f} %, against {pct['fixed'][0]:.3f} % and "
            f"{pct['fixed'][1]:.3f} % at one zoom" in hist)
    assert steps["photos"]["frames"] == 96 and f"sacre_coeur's {96}-frame path" in hist
    assert np.isclose(steps["photos"]["largest_step"] / steps["photos"]["median_step"], 1.0,
                      atol=0.01)
