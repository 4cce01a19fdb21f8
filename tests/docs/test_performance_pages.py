"""docs/performance.md's and the README's times and memory (the one-shot runs, stage times,
bf16 on the CPU, processes and threads) agree with the result files they quote.

As tests/docs/test_pages.py; split from it by topic in the ninety-third session.
"""

from __future__ import annotations

import re

from tests.docs.numbers import (
    PERF,
    REPO,
    RESULTS,
    clock,
    page_text,
    readme_notes,
    readme_performance,
    recorded_walls,
    result,
)


def test_performance_depth_stage_with_the_frames_maps_follows_its_files():
    """docs/performance.md: the depth stage's seconds per view without and with the novel
    frames' maps are the files', and WS/depth is the same either way (its digest)."""
    text = page_text("docs/performance.md")
    names = {"sceaux": "sceaux_castle", "et": "et", "lund": "lund"}
    for sc, name in names.items():
        a, b = (result(f"depth_frames_time_dev_{sc}_{arm}_s44.json")
                ["depth_stage"] for arm in ("none", "frames"))
        assert f"{name} {a['seconds_per_view']:.2f} / {b['seconds_per_view']:.2f}" in text, sc
        assert a["digest"] == b["digest"] and b["seconds_per_view"] > a["seconds_per_view"]


def test_the_sample_gives_the_same_deflared_photos_with_the_frames_maps():
    """docs/eval.md (the README's rows): the one-shot at the forty-fourth session's defaults
    (the video's own depth maps) gives the sample's de-flared photos of the forty-first
    session to the digit."""
    new = result("sample_oneshot_cpu_s44.json")["mean"]
    old = result("sample_oneshot_cpu_s41_expo.json")["mean"]
    assert new == old
    readme = page_text("docs/eval.md")
    assert "to the last digit in 10:34 wall" in readme and "sample_oneshot_cpu_s44.json" in readme


def test_the_one_cost_volume_one_shot_is_the_same_and_its_depth_stage_faster():
    """docs/performance.md: the one-shot with both depth winners from one cost volume gives
    the same photos and its depth stage the quoted seconds."""
    a = result("sample_oneshot_cpu_s44.json")
    b = result("sample_oneshot_cpu_s44b.json")
    assert a["mean"] == b["mean"]
    text = page_text("docs/performance.md")
    sa, sb = (x["stages"]["depth"]["seconds"] for x in (a, b))
    assert f"{sb:.1f} s ({sa:.1f} s with a second sweep per view)" in text and sb < sa


def test_performance_sample_stage_times_of_the_forty_fifth_session_are_the_files():
    """docs/performance.md: the sample one-shot's fine-tune and video times before and with
    the new fill of novel frames are the two files', and their de-flared photos agree."""
    text = page_text("docs/performance.md")
    runs = [result(f) for f in
            ("sample_oneshot_cpu_s45.json", "sample_oneshot_cpu_s45_before.json")]
    for r in runs:
        st = r["stages"]
        assert (f"fine-tuning {st['finetune']['seconds']:.1f} s, the 48 frames "
                f"{st['render:interpolate']['seconds']:.1f} s") in text
    assert runs[0]["mean"] == runs[1]["mean"]
    ratio = (runs[0]["stages"]["render:interpolate"]["seconds"]
             / runs[1]["stages"]["render:interpolate"]["seconds"])
    assert f"take {ratio:.1f} times as long on the sample" in text


def test_performance_frames_in_two_processes_are_the_files():
    """docs/performance.md: the table of one process against two is the two files' fastest
    passes (rows 0 and 1: chunk 256 with workers 1 and 2), its speed-ups their ratios, and
    the files say the two processes' frames differ from one's by at most one level."""
    text = page_text("docs/performance.md")
    for n in (48, 12):
        rows = result(f"render_speed_cpu_{n}f_s46.json")["rows"]
        one, two = rows[0], rows[1]
        assert (one["chunk"], one["workers"], two["chunk"], two["workers"]) == (256, 1, 256, 2)
        assert (f"{one['s_per_frame']:.2f} s per frame | {two['s_per_frame']:.2f} s per frame | "
                f"{one['s_per_frame'] / two['s_per_frame']:.2f}x |") in text, n
        assert one["max_abs_diff"] == 0 and two["max_abs_diff"] == 1, n


def test_performance_fine_tune_threads_and_the_sample_of_the_forty_sixth_session():
    """docs/performance.md: the fine-tune's steps/s on one thread and on two are the runs'
    lines in finetune_threads_cpu_s46.txt (one faster in every pair), and the sample's stage
    times and scores are sample_oneshot_cpu_s46.json's."""
    text = page_text("docs/performance.md")
    runs = [(int(m[1]), float(m[2])) for m in re.finditer(
        r"^threads (\d): finetune: 300/300 \(\d+ s\) speed=([\d.]+)",
        (RESULTS / "finetune_threads_cpu_s46.txt").read_text(), re.M)]
    assert [t for t, _ in runs] == [1, 2, 1, 2]
    one, two = [v for t, v in runs if t == 1], [v for t, v in runs if t == 2]
    assert min(one) > max(two)
    assert (f"{one[0]:.2f} and {one[1]:.2f} steps/s on one thread against {two[0]:.2f} and "
            f"{two[1]:.2f} on two") in text
    rec = result("sample_oneshot_cpu_s46.json")
    st = rec["stages"]
    assert (f"fine-tuning {st['finetune']['seconds']:.1f} s at 7.2 steps/s, the 48 frames "
            f"{st['render:interpolate']['seconds']:.1f} s "
            f"({st['render:interpolate']['seconds'] / 48:.1f} s each), the de-flared photos "
            f"{st['render:inputs']['seconds']:.1f} s; {rec['mean']['psnr_flare']:.2f} / "
            f"{rec['mean']['psnr']:.2f} dB") in text
    assert rec["model"]["provenance"]["machine"]["torch_threads"] == 2
    assert round(3000 / st["finetune"]["seconds"], 1) == 7.2


def test_performance_one_shot_before_and_after_the_fill_and_the_speed_ups():
    """docs/performance.md's table of the sample's main job at f4908b8 and at this session's
    code is the two files' (stage times, scores, commits, threads of the fine-tune)."""
    text = page_text("docs/performance.md")
    for f, commit, threads in (("sample_oneshot_cpu_s46_f4908b8.json", "f4908b8", 2),
                               ("sample_oneshot_cpu_s46_head.json", "0f54f5b", 1)):
        rec = result(f)
        st = rec["stages"]
        assert rec["code"]["commit"].startswith(commit), f
        assert rec["model"]["provenance"]["machine"]["torch_threads"] == threads, f
        cells = (f"{st['finetune']['seconds']:.1f} s | {st['render:inputs']['seconds']:.1f} s | "
                 f"{st['render:interpolate']['seconds']:.1f} s | {rec['mean']['psnr_flare']:.2f} "
                 f"/ {rec['mean']['psnr']:.2f} dB |")
        assert cells in text, f
    a, b = (result(f)["mean"]["psnr_flare"] for f in
            ("sample_oneshot_cpu_s46_head.json", "sample_oneshot_cpu_s46_f4908b8.json"))
    assert f"flare region {a - b:.3f} dB" in text


def test_performance_fine_tune_in_two_processes_is_the_files():
    """docs/performance.md, "The fine-tune in two processes": the speed table is the two
    benchmark files' (fastest passes, their ratio, the loops' best it/s), the memory and
    the weights' difference theirs, the one-shot table the two fresh-clone runs'; the
    README, goals.md, options.md and the option's help quote the same speed-ups."""
    import inspect

    from pipeline.finetune import FinetuneConfig

    text = page_text("docs/performance.md")
    speed = {}
    for name in ("sample", "sceaux1008"):
        rec = result(f"finetune_split_cpu_{name}_s47.json")
        one, two = rec["rows"]
        assert (one["workers"], two["workers"], rec["iters"]) == (1, 2, 1000)
        loops = [max(p["loop_it_per_s"] for p in r["passes"]) for r in (one, two)]
        assert (f"| {one['steps_per_s']:.2f} steps/s | {two['steps_per_s']:.2f} steps/s | "
                f"{two['speedup']:.2f}x | {loops[0]:.2f} / {loops[1]:.2f} it/s |") in text, name
        assert two["speedup"] > 1.2 and one["max_weight_diff"] == 0.0
        assert f"{rec['helper_peak_rss_mb']:.0f} MB" in text
        assert f"{two['max_weight_diff']:.3f}" in text
        speed[name] = f"{two['speedup']:.2f}x"
    for f, commit in (("sample_oneshot_cpu_s47_f70850f.json", "f70850f"),
                      ("sample_oneshot_cpu_s47_head.json", "cf63f10")):
        rec = result(f)
        st = rec["stages"]
        assert rec["code"]["commit"].startswith(commit), f
        cells = (f"{st['finetune']['seconds']:.1f} s | {st['render:inputs']['seconds']:.1f} s | "
                 f"{st['render:interpolate']['seconds']:.1f} s | {rec['mean']['psnr_flare']:.2f} "
                 f"/ {rec['mean']['psnr']:.2f} dB |")
        assert f"| {commit} " in text and cells in text, f
    base = result("sample_oneshot_cpu_s47_f70850f.json")
    old = result("sample_oneshot_cpu_s46_head.json")
    assert base["mean"] == old["mean"]  # "scored to the digit": the runs are deterministic
    sizes = "x".join(str(int(v)) for v in (1046, 771))
    assert sizes in text
    summary = readme_performance()
    goals = page_text("docs/goals.md")
    options = page_text("docs/options.md")
    source = " ".join(inspect.getsource(FinetuneConfig).split())  # the option's help
    for page, body in (("README", summary), ("goals", goals), ("help", source)):
        assert speed["sample"] in body and speed["sceaux1008"] in body, page
    assert speed["sceaux1008"] in options
    for body in (summary, goals, text):
        assert "7:32.0" in body and "9:18.9" in body


def test_readme_sample_row_is_todays_run_and_the_rounding_paths_its_files():
    """README: the sample's row is the seventy-third session's fresh clone (the mask stage's
    padded runs), beside its first commit's and the forty-eighth session's (bf16 on this CPU);
    the earlier runs docs/eval.md names are their files'; the fp32 clone at the session's
    first commit repeats the forty-seventh session's to the digit, whose last clone repeated
    its head's."""
    readme = page_text("README.md")
    rows = page_text("docs/eval.md")
    pixels = result("sample_oneshot_cpu_s73_pixels.json")
    assert pixels["code"]["commit"].startswith("ae048c4")  # the pixel-wise default
    assert f"{pixels['mean']['psnr_flare']:.2f} / {pixels['mean']['psnr']:.2f}" in rows
    # the seventy-ninth session's fresh clone; the seventy-third session's code on the same
    # machine scores the same to the digit (the machine moved the row)
    s79 = result("sample_oneshot_cpu_s79_head.json")
    again = result("sample_oneshot_cpu_s79_ae048c4.json")
    assert again["code"]["commit"].startswith("ae048c4") and again["mean"] == s79["mean"]
    assert s79["machine"]["platform"] == again["machine"]["platform"]
    assert f"{s79['mean']['psnr_flare']:.2f} / {s79['mean']['psnr']:.2f}" in rows
    # the row since the eighty-fifth session (the fine-tune pads the portrait photo); that
    # session's first commit, run just before on its machine, repeats the s79 clone exactly
    s85 = result("sample_oneshot_cpu_s85_head.json")
    first = result("sample_oneshot_cpu_s85_313090a.json")
    assert first["code"]["commit"].startswith("313090a") and first["mean"] == s79["mean"]
    assert s85["machine"]["platform"] == first["machine"]["platform"]
    assert f"{s85['mean']['psnr_flare']:.2f} / {s85['mean']['psnr']:.2f}" in rows
    # the row since the hundredth session: a fresh clone at the ninety-ninth session's
    # defaults, which repeats that session's run at fbf5dc8 to the digit
    today = result("sample_oneshot_cpu_s100_head.json")
    assert today["code"]["commit"].startswith("7e39685")
    assert today["mean"] == result("sample_oneshot_cpu_s99.json")["mean"]
    assert (f"(the main job above) | {today['mean']['psnr_flare']:.2f} / "
            f"{today['mean']['psnr']:.2f} |") in readme
    assert f"{today['mean']['psnr_flare']:.2f} / {today['mean']['psnr']:.2f}" in rows
    first_row = f"{first['mean']['psnr_flare']:.2f} / {first['mean']['psnr']:.2f}"
    notes = readme_notes()  # the README's notes on the row, kept in docs/eval.md
    assert f"{first_row} at that session's first commit" in notes
    now = result("sample_oneshot_cpu_s73_head.json")
    assert now["code"]["commit"].startswith("5b30369")  # the regions form
    assert f"{now['mean']['psnr_flare']:.2f} / {now['mean']['psnr']:.2f}" in rows
    for f in ("sample_oneshot_cpu_s73_3938847.json", "sample_oneshot_cpu_s48_head.json"):
        m = result(f)["mean"]
        assert f"{m['psnr_flare']:.2f} / {m['psnr']:.2f}" in notes and f in rows, f
    perf = page_text("docs/performance.md")
    old = result("sample_oneshot_cpu_s73_3938847.json")
    assert old["code"]["commit"].startswith("3938847")  # the plain run's last commit
    assert (f"the mask stage {now['stages']['mask']['seconds']:.1f} s against "
            f"{old['stages']['mask']['seconds']:.1f} s for the 8 views") in perf
    assert (f"the mask stage {pixels['stages']['mask']['seconds']:.1f} s, peak 0.99 GB, the "
            f"photos {pixels['mean']['psnr_flare']:.2f} / {pixels['mean']['psnr']:.2f} dB") in perf
    s47 = result("sample_oneshot_cpu_s47_head.json")["mean"]
    final = result("sample_oneshot_cpu_s47_final.json")
    fp32 = result("sample_oneshot_cpu_s48_0d97d56.json")
    assert final["mean"] == s47 == fp32["mean"] and final["code"]["commit"].startswith("be7779b")
    st = final["stages"]
    perf = page_text("docs/performance.md")
    assert (f"fine-tuning {st['finetune']['seconds']:.1f} s, the 48 frames "
            f"{st['render:interpolate']['seconds']:.1f} s, and the same scores") in perf
    for f, words in (("sample_oneshot_cpu_s47_head.json", "(the forty-seventh session, fp32"),
                     ("sample_oneshot_cpu_s46_head.json", "(the forty-sixth session"),
                     ("sample_oneshot_cpu_s46.json", "(its run on two threads"),
                     ("sample_oneshot_cpu_s41_expo.json", "(the forty-first session")):
        m = result(f)["mean"]
        assert f"{m['psnr_flare']:.2f} / {m['psnr']:.2f} {words}" in rows, f


def test_bf16_oneshot_pair_is_its_files():
    """docs/performance.md, README and goals.md: the bf16 one-shot against fp32 (stage times,
    scores, the difference in the flare region) are the two fresh clones' files, and the
    runs did train as said (bf16 recorded in the new one only)."""
    old = result("sample_oneshot_cpu_s48_0d97d56.json")
    new = result("sample_oneshot_cpu_s48_head.json")
    perf = page_text("docs/performance.md")
    summary = readme_performance()
    goals = page_text("docs/goals.md")
    o, n = old["stages"], new["stages"]
    for stage in ("finetune", "render:interpolate"):
        pair = f"{o[stage]['seconds']:.1f} s against {n[stage]['seconds']:.1f} s"
        assert pair in perf, stage
        assert f"{n[stage]['seconds']:.1f} s against {o[stage]['seconds']:.1f} s" in summary
    mo, mn = old["mean"], new["mean"]
    assert (f"{mn['psnr_flare']:.2f} / {mn['psnr']:.2f} dB (flare region / whole) against "
            f"{mo['psnr_flare']:.2f} / {mo['psnr']:.2f} in fp32, "
            f"{mn['psnr_flare'] - mo['psnr_flare']:+.2f} dB") in perf
    assert (f"scored {mn['psnr_flare']:.2f} dB against {mo['psnr_flare']:.2f} in fp32") in goals
    assert "6:39.07 wall at 0d97d56" in perf and "against 5:45.57 at 978a505" in perf
    for body in (summary, goals):
        assert "5:45.6 against 6:39.1" in body
    assert old["code"]["commit"].startswith("0d97d56") and new["code"]["commit"].startswith(
        "978a505")
    assert new["model"]["provenance"]["train"]["cpu_bf16"] is True
    import inspect

    from pipeline.finetune import FinetuneConfig

    pair = f"{n['finetune']['seconds']:.1f} s against {o['finetune']['seconds']:.1f} s in fp32"
    assert pair in " ".join(inspect.getsource(FinetuneConfig).split())
    assert pair in page_text("docs/options.md")
    assert f"({o['finetune']['seconds'] / n['finetune']['seconds']:.2f}x in the default two" in perf
    assert "cpu_bf16" not in old["model"]["provenance"]["train"]  # before the setting


def test_performance_bf16_without_native_bf16_is_its_file():
    """docs/performance.md's frames on a CPU without native bf16 (emulated by limiting oneDNN
    and ATen to AVX2) are render_bf16_cpu_avx2_sample_s48.json's, and the run did see no
    native bf16."""
    text = page_text("docs/performance.md")
    r = result("render_bf16_cpu_avx2_sample_s48.json")
    assert r["native_bf16"] is False and r["onednn_max_cpu_isa"] == "AVX2"
    assert r["aten_cpu_capability"] == "AVX2"
    assert (f"{r['s_per_frame']['fp32']:.2f} s per frame in fp32 and "
            f"{r['s_per_frame']['bf16']:.2f} s with bf16, {1 / r['speedup']:.1f} times "
            "slower") in text


def test_bf16_rule_table_and_decision_are_the_judgments():
    """docs/performance.md's bf16 rule table (candidate minus base, per scene and mean) and
    its render-alone means are bf16_judge_speed_s48.json's and rbf16_judge_speed_s48.json's;
    both pass, and the default in the code follows (AUTO_BF16); options.md quotes the same
    means and the render-alone bound."""
    text = (REPO / "docs" / "performance.md").read_text()
    flat = " ".join(text.split())
    j = result("bf16_judge_speed_s48.json")
    r = result("rbf16_judge_speed_s48.json")
    assert j["decision"] == "passes" and r["decision"] == "passes" and j["rule"] == "speed"
    # the module's value as written, not the suite's (conftest holds the suite to fp32)
    assert "\nAUTO_BF16 = True\n" in (REPO / "gnfr" / "renderer.py").read_text()
    names = {"sceaux": "sceaux_castle", "et": "et", "lund": "lund"}
    for key, d in [*j["per_scene"].items(), ("mean", j["mean"])]:
        assert (f"| {names.get(key, key)} | {d['psnr_flare']:+.3f} | {d['psnr']:+.3f} | "
                f"{d['ssim']:+.3f} | {d['held']:+.3f} |") in text, key
    assert (f"flare region {r['mean']['psnr_flare']:+.3f} dB, novel views "
            f"{r['mean']['held']:+.3f} dB on the mean") in flat
    assert max(abs(v) for d in r["per_scene"].values() for v in d.values()) < 0.01
    options = page_text("docs/options.md")
    assert (f"region {j['mean']['psnr_flare']:+.3f} dB and novel views "
            f"{j['mean']['held']:+.3f} dB on the mean") in options


def test_bf16_test_scene_table_is_the_evals():
    """docs/performance.md's test-scene table (fp32 and bf16 evals of kermit and cyprus) and
    goals.md's margins are the four eval files', and the arms trained as labelled."""
    text = (REPO / "docs" / "performance.md").read_text()
    goals = page_text("docs/goals.md")
    for scene in ("kermit", "cyprus"):
        for arm in ("fp32", "bf16"):
            r = result(f"{scene}_synth_gnfr_gnt_cpu_s48_{arm}.json")
            g, t = r["methods"]["gnfr"], r["methods"]["gnt"]
            margin = g["inputs"]["psnr_flare"] - t["inputs"]["psnr_flare"]
            row = (f"| {scene} | {arm} | {g['inputs']['psnr_flare']:.2f} / "
                   f"{g['inputs']['psnr']:.2f} | {t['inputs']['psnr_flare']:.2f} / "
                   f"{t['inputs']['psnr']:.2f} | {margin:+.2f} | {g['heldout']['psnr']:.2f} | "
                   f"{t['heldout']['psnr']:.2f} |")
            assert row in text, (scene, arm)
            if arm == "bf16":
                assert f"{scene} {margin:+.2f}" in goals, scene
            assert r["provenance"]["code"]["commit"].startswith("66d2311")
            for m in ("gnfr", "gnt"):
                assert r["methods"][m]["provenance"]["trained"]["train"]["cpu_bf16"] is (
                    arm == "bf16")


def test_performance_bf16_frames_exploration_is_its_file():
    """docs/performance.md, options.md and ``render --bf16``'s help: its times, speed-up and
    differences are render_bf16_cpu_sample_s47.json's."""
    import inspect

    text = page_text("docs/performance.md")
    r = result("render_bf16_cpu_sample_s47.json")
    assert r["native_bf16"] is True
    assert (f"{r['s_per_frame']['fp32']:.2f} s per frame in fp32 against "
            f"{r['s_per_frame']['bf16']:.2f} s with bf16 autocast, {r['speedup']:.2f}x") in text
    assert (f"{r['psnr_bf16_vs_fp32']:.1f} dB from the fp32 frames, but "
            f"{r['share_of_values_differing'] * 100:.1f} % of the values differ and the largest "
            f"difference is {r['max_abs_diff']} levels") in text
    options = page_text("docs/options.md")
    assert (f"frames {r['speedup']:.2f}x faster on this EPYC, {r['psnr_bf16_vs_fp32']:.1f} dB "
            f"from the fp32 frames with a few pixels up to {r['max_abs_diff']} levels "
            "off") in options
    from pipeline.render.config import RenderConfig

    source = " ".join(inspect.getsource(RenderConfig).split())
    assert f"rendered {r['speedup']:.2f}x faster" in source


def test_slower_machine_oneshot_is_its_file():
    """docs/performance.md, "A slower machine": the fresh clone's stage times and scores are
    sample_oneshot_cpu_s56_head.json's, and the README's range reaches its wall time."""
    r = result("sample_oneshot_cpu_s56_head.json")
    perf = page_text("docs/performance.md")
    st = r["stages"]
    assert (f"the fine-tune {st['finetune']['seconds']:.1f} s" in perf
            and f"the 48 frames {st['render:interpolate']['seconds']:.1f} s" in perf)
    m = r["mean"]
    assert f"scored {m['psnr_flare']:.2f} / {m['psnr']:.2f} dB (flare region / whole)" in perf
    assert r["code"]["commit"].startswith("ec3446a")
    assert "taken 6-23 minutes wall" in page_text("README.md")
    assert "22:32 on the slower machine" in page_text("README.md")


def test_readme_sample_time_today_is_the_paired_idle_runs():
    """README, "Run the main job": today's wall time and the run before the ninety-ninth
    session's defaults are the hundredth session's paired idle one-shots as
    docs/results/README.md records them, and the added stage's seconds are its file's."""
    (head, before), _ = recorded_walls(r"\| `sample_oneshot_cpu_s100_head\.json`")
    head_run = result("sample_oneshot_cpu_s100_head.json")
    before_run = result("sample_oneshot_cpu_s100_cda7581.json")
    assert before_run["code"]["commit"].startswith("cda7581")
    assert "render:inputs_frames" in head_run["stages"]
    assert "render:inputs_frames" not in before_run["stages"]
    added = head_run["stages"]["render:inputs_frames"]["seconds"]
    readme = " ".join(page_text("README.md").split())
    assert (f"at today's code {clock(head)} on an idle machine of that kind (the hundredth "
            f"session), against {clock(before)} for the code before the ninety-ninth "
            f"session's defaults run just after it, of which {added:.0f} s are the frames") \
        in readme


def test_readme_sample_time_is_the_recent_runs():
    """README, "Run the main job": the range of the sample's wall times and the largest peak
    are the eightieth to eighty-seventh sessions' one-shots as docs/results/README.md records
    them (`time -v`'s figures, not in the result files)."""
    walls, peaks = recorded_walls(r"\| `sample_oneshot_cpu_s8\d_")
    assert len(walls) == len(peaks) >= 6
    readme = page_text("README.md")
    assert f"it has taken {clock(min(walls))} to {clock(max(walls))} wall in the eightieth to " \
           f"eighty-seventh sessions' runs, peak memory up to {max(peaks):.2f} GB" in readme


def test_the_two_nearest_views_cost_is_the_oneshot_files():
    """docs/performance.md's one-shot pair of the eighty-first session: the frames' seconds
    as the files record them, the same scores both ways, the earlier commit as named."""
    head = result("sample_oneshot_cpu_s81_head.json")
    before = result("sample_oneshot_cpu_s81_b47cd36.json")
    assert before["code"]["commit"].startswith("b47cd36") and head["mean"] == before["mean"]
    perf = page_text("docs/performance.md")
    for d in (head, before):
        assert f"the frames {d['stages']['render:interpolate']['seconds']:.1f} s" in perf \
            or f"the 48 frames {d['stages']['render:interpolate']['seconds']:.1f} s" in perf
    assert (f"({head['mean']['psnr_flare']:.2f} / {head['mean']['psnr']:.2f} dB; the count "
            "is not theirs)") in perf


def test_the_key_spot_oneshot_is_its_file():
    """docs/performance.md's one-shot with the key spot: its frames' seconds and the scores
    of the runs before it."""
    ks = result("sample_oneshot_cpu_s81_keyspot.json")
    head = result("sample_oneshot_cpu_s81_head.json")
    assert ks["mean"] == head["mean"] and ks["code"]["commit"].startswith("1b6952f")
    perf = page_text("docs/performance.md")
    assert f"the frames {ks['stages']['render:interpolate']['seconds']:.1f} s, the same scores" \
        in perf


def test_the_eightieth_oneshot_fine_tune_is_its_file():
    """docs/performance.md compares the eighty-first session's fine-tunes with the
    eightieth's one-shot, whose stage times are its file's."""
    s80 = result("sample_oneshot_cpu_s80_b47cd36.json")
    head = result("sample_oneshot_cpu_s81_head.json")
    assert s80["mean"] == head["mean"]
    perf = page_text("docs/performance.md")
    assert f"against {s80['stages']['finetune']['seconds']:.1f} s, code it does not touch" in perf


def test_performance_apart_timing_of_the_eighty_eighth_session_is_its_file():
    """docs/performance.md quotes each arm's training seconds per round and the mean of the
    undisturbed rounds 0 and 2 from apart_time_ab_sample_s88.json."""
    text = page_text("docs/performance.md")
    runs = result("apart_time_ab_sample_s88.json")["runs"]
    means = []
    for arm in ("pad", "apart", "stretch"):
        secs = [r["train_seconds"] for r in sorted(runs, key=lambda r: r["round"])
                if r["arm"] == arm]
        assert " / ".join(f"{s:g}" for s in secs) in text, arm
        means.append(f"{(secs[0] + secs[2]) / 2:g}")
    assert f"({means[0]}, {means[1]} and {means[2]} s)" in text


def test_performance_apart_timing_rerun_is_its_file():
    """docs/performance.md quotes the idle rerun's seconds per round, means and ratios
    (apart_time_ab_sample_s88b.json)."""
    text = page_text("docs/performance.md")
    rec = result("apart_time_ab_sample_s88b.json")
    runs, summ = rec["runs"], rec["summary"]
    for arm in ("pad", "apart", "stretch"):
        secs = [r["train_seconds"] for r in sorted(runs, key=lambda r: r["round"])
                if r["arm"] == arm]
        assert " / ".join(f"{s:g}" for s in secs) in text, arm
    assert (f"the means {summ['pad']['train_s']:.2f}, {summ['apart']['train_s']:.2f} and "
            f"{summ['stretch']['train_s']:.2f} s") in text
    assert f"apart trained {summ['apart']['train_ratio']:.3f} times" in text
    assert f"stretched views {summ['stretch']['train_ratio']:.3f} times" in text
    assert f"cost {1 / summ['stretch']['train_ratio']:.3f} times the stretched" in text


def test_the_sample_in_fp32_on_a_cpu_without_native_bf16_is_its_file():
    """docs/eval.md: the ninety-second session's one-shot on a CPU without native bf16 trained
    in fp32 (its model's record), at 5b95ea5, and scored what the page says against the
    eighty-fifth session's run, trained in bf16 (the README's row until the hundredth)."""
    fp32 = result("sample_oneshot_cpu_s92_fp32.json")
    row = result("sample_oneshot_cpu_s85_head.json")
    assert fp32["model"]["provenance"]["train"]["cpu_bf16"] is False
    assert row["model"]["provenance"]["train"]["cpu_bf16"] is True
    assert fp32["code"]["commit"].startswith("5b95ea5") and fp32["code"]["dirty_files"] == [
        "oneshot.log"]
    f, r = fp32["mean"], row["mean"]
    assert f["psnr_flare_input"] == r["psnr_flare_input"]  # the same photos
    assert (f"scored {f['psnr_flare']:.2f} / {f['psnr']:.2f} dB (flare region / whole; "
            f"`docs/results/sample_oneshot_cpu_s92_fp32.json`) against the eighty-fifth "
            f"session's bf16 run's "
            f"{r['psnr_flare']:.2f} / {r['psnr']:.2f}") in page_text("docs/eval.md")


def test_the_sample_after_the_ninety_fifth_sessions_splits_scores_as_before():
    """docs/eval.md: the README's main job after the fine-tune's and the render's functions
    were split (ninety-fifth session) scores the de-flared photos as the idle fp32 run did,
    every view to the digit, from a clean commit but for the run's own log."""
    new, idle = result("sample_oneshot_cpu_s95_fp32.json"), result(
        "sample_oneshot_cpu_s92_fp32_idle.json")
    assert new["code"]["commit"].startswith("ea7da94")
    assert new["code"]["dirty_files"] == ["oneshot.log"]
    assert new["model"]["provenance"]["train"]["cpu_bf16"] is False
    assert new["mean"] == idle["mean"] and new["views"] == idle["views"]
    assert ("at ea7da94, after the fine-tune's training function and the render's record were "
            "split into parts (meant to change nothing), it gave the same scores to the last "
            "digit, on every view (`sample_oneshot_cpu_s95_fp32.json`)") in page_text(
        "docs/eval.md")
    later = result("sample_oneshot_cpu_s96_fp32.json")  # after the ninety-sixth's changes
    assert later["code"]["commit"].startswith("1b10d02")
    assert later["code"]["dirty_files"] == ["oneshot.log"]
    assert later["model"]["provenance"]["train"]["cpu_bf16"] is False
    assert later["mean"] == new["mean"] and later["views"] == new["views"]
    wall = recorded_walls(r"\| `sample_oneshot_cpu_s96_fp32\.json`")[0][0]
    assert (f"at 1b10d02, after that session's refactors and the `--streak-scales` option (off "
            f"by default), it gave the same scores to the last digit, on every view, in "
            f"{clock(wall)} wall (`sample_oneshot_cpu_s96_fp32.json`)") in page_text(
        "docs/eval.md")
    # the README's fp32 span is the two fp32 walls on an otherwise idle machine
    walls = [recorded_walls(rf"\| `{name}`")[0][0]
             for name in (r"sample_oneshot_cpu_s92_fp32_idle\.json",
                          r"sample_oneshot_cpu_s95_fp32\.json")]
    lo, hi = int(min(walls) // 60), int(max(walls) // 60) + 1
    assert f"and {lo}-{hi} minutes in fp32 (above)" in page_text("README.md")


def test_the_samples_fp32_time_is_its_idle_run():
    """README: the sample's one-shot in fp32 on the idle machine without native bf16 (its
    stage times from the file, the wall time from docs/results/README.md's row); it repeats
    the first fp32 run's scores to the digit."""
    idle = result("sample_oneshot_cpu_s92_fp32_idle.json")
    first = result("sample_oneshot_cpu_s92_fp32.json")
    assert idle["mean"] == first["mean"]
    assert idle["model"]["provenance"]["train"]["cpu_bf16"] is False
    st = idle["stages"]
    (wall,), _ = recorded_walls(r"\| `sample_oneshot_cpu_s92_fp32_idle\.json`")
    assert (f"{clock(wall)} on an idle 2-core EPYC without it (the fine-tune "
            f"{st['finetune']['seconds']:.0f} s, the 48 frames "
            f"{st['render:interpolate']['seconds']:.0f} s") in page_text("README.md")
    perf = page_text(PERF)
    bf16 = result("sample_oneshot_cpu_s85_head.json")["stages"]
    assert (f"the fine-tune {st['finetune']['seconds']:.1f} s and the 48 frames "
            f"{st['render:interpolate']['seconds']:.1f} s, against "
            f"{bf16['finetune']['seconds']:.1f} s and {bf16['render:interpolate']['seconds']:.1f}"
            " s in the eighty-fifth session's bf16 run") in perf


def test_malloc_settings_judged_by_their_files():
    """docs/performance.md, "Freed memory kept by malloc": the render A/B's numbers are its
    file's (each arm's fastest pass and medians, the frames identical), the one-shot pair
    scored the same to the last digit, its stage times are the files', and the rule's
    verdict follows from the page's peak memories (1.40 against 1.13 GB: over 1.10x)."""
    text = page_text("docs/performance.md")
    ab = result("malloc_ab_render_sample_s97.json")
    s = ab["summary"]
    assert ab["max_abs_diff"] == 0 and ab["values_differing"] == 0 and ab["frames"] == 8
    assert (f"fastest pass {s['on']['fastest_wall_s']:.1f} s with the settings against "
            f"{s['off']['fastest_wall_s']:.1f} s without ({s['fastest_wall_ratio_on_off']:.3f}x), "
            f"the median pass {s['on']['median_minor_faults'] / 1e6:.2f} million page faults "
            f"against {s['off']['median_minor_faults'] / 1e6:.1f} million and "
            f"{s['on']['median_kernel_s']:.1f} s of kernel time against "
            f"{s['off']['median_kernel_s']:.1f} s") in text
    on, off = (result(f"sample_oneshot_cpu_s97_malloc_{a}.json") for a in ("on", "off"))
    assert on["views"] == off["views"] and on["code"]["commit"] == off["code"]["commit"]
    assert on["code"]["dirty_files"] == off["code"]["dirty_files"] == ["oneshot.log"]
    row = (f"| fine-tune / 48 frames | {on['stages']['finetune']['seconds']:.1f} s / "
           f"{on['stages']['render:interpolate']['seconds']:.1f} s | "
           f"{off['stages']['finetune']['seconds']:.1f} s / "
           f"{off['stages']['render:interpolate']['seconds']:.1f} s |")
    assert row in text
    assert (f"({on['mean']['psnr']:.3f} / {on['mean']['psnr_flare']:.3f} dB, whole photo / "
            "flare region)") in text
    frames = (on["stages"]["render:interpolate"]["seconds"]
              / off["stages"]["render:interpolate"]["seconds"])
    assert f"its frames {frames:.3f} times" in text
    assert "| peak memory (`time -v`) | 1.40 GB | 1.13 GB |" in text
    assert round(1.40 / 1.13, 2) == 1.24 > 1.10 and "peak memory rose 1.24 times" in text


def test_malloc_one_shots_time_rows_are_their_logs():
    """The one-shot pair's wall, peak memory, kernel time and page faults on
    docs/performance.md are the `time -v` logs' (GB: kbytes / 1e6, two decimals)."""
    text = page_text("docs/performance.md")
    got = {}
    for arm in ("on", "off"):
        log = (RESULTS / f"sample_oneshot_cpu_s97_malloc_{arm}_time.log").read_text()
        field = {k.strip(): v.strip() for k, v in
                 (ln.rsplit(": ", 1) for ln in log.splitlines() if ": " in ln)}
        minutes, seconds = field["Elapsed (wall clock) time (h:mm:ss or m:ss)"].split(":")
        got[arm] = (f"{minutes}:{float(seconds):04.1f}",
                    int(field["Maximum resident set size (kbytes)"]) / 1e6,
                    float(field["System time (seconds)"]),
                    int(field["Minor (reclaiming a frame) page faults"]) / 1e6)
    on, off = got["on"], got["off"]
    assert f"| wall | {on[0]} | {off[0]} |" in text
    assert f"| peak memory (`time -v`) | {on[1]:.2f} GB | {off[1]:.2f} GB |" in text
    assert f"| kernel time / user time | {on[2]:.1f} s /" in text and f"| {off[2]:.1f} s /" in text
    assert f"| minor page faults | {on[3]:.2f} million | {off[3]:.1f} million |" in text


def test_lund_capture_sixty_one_sessions_later_is_its_file():
    """docs/performance.md, "A larger capture": the ninety-eighth session's shares marked and
    changed, and the frames' seconds each, are clean_capture_lund_s98.json's (its stage
    seconds are held by test_pages.py's table of quotes)."""
    perf = page_text("docs/performance.md")
    rec = result("clean_capture_lund_s98.json")
    mean, stages = rec["mean"], rec["stages"]
    assert (f"masks marked {100 * mean['marked']:.3f} % of the pixels (the network "
            f"{100 * mean['marked_network']:.3f} %, the other photos' check "
            f"{100 * mean['added_by_views']:.3f} %)") in perf
    assert f"changed {100 * mean['changed']:.3f} % by more than 2 of 255" in perf
    old = result("clean_capture_lund_s37.json")
    assert f"{100 * old['mean']['changed']:.2f} %" in perf
    assert mean["changed"] < old["mean"]["changed"] / 2.5  # "about a third"
    per_frame = [stages["render:interpolate"]["seconds"] / 48,
                 old["stages"]["render:interpolate"]["seconds"] / 48]
    assert f"frames take {per_frame[0]:.0f} s each against {per_frame[1]:.0f} s" in perf
    assert len(rec["views"]) == 29
