"""The README's, the model cards' and docs/*.md's numbers agree with the result files they quote.

Each entry names a page, a JSON file under docs/results/, a path into it and how the page
writes the number; the test fails when a result file is re-measured and the page is not
updated (or the other way round), so published numbers cannot drift from their source.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.conftest import load_benchmark
from tests.docs.numbers import (
    FERN,
    FERN4,
    PERF,
    REPO,
    RESULTS,
    SAMPLE,
    assert_quoted,
    fill_row,
    page_text,
    readme_notes,
    readme_performance,
    result,
)

CHECKS = [
    # page, file, path, format
    # the GN-FR card: the shipped files' numbers
    *[("gnfr/weights/gnfr.md", f"pretrain_zero_shot_{s}_rs101500.json", f"rows/{i}/{m}",
       "{:.2f}" if m == "psnr" else "{:.3f}")
      for s in ("sceaux", "et") for i in (0, 1) for m in ("psnr", "ssim")],
    *[("gnfr/weights/gnfr.md", "pretrain_zero_shot_et_paper_s23P.json", f"rows/0/{m}", f)
      for m, f in (("psnr", "{:.2f}"), ("ssim", "{:.3f}"))],
    *[("gnfr/weights/gnfr.md", "finetune_ab_paper_init11000_dev_et.json", f"{row}/{m}",
       "{:.3f}" if m.endswith("ssim") else "{:.2f}")
      for row in ("base", "init-gnfr_paper")
      for m in ("heldout_psnr", "heldout_ssim", "flare_region_psnr")],
    *[("gnfr/weights/gnfr.md", f, f"clean/methods/gnfr_hybrid/heldout/{m}",
       "{:.2f}" if m == "psnr" else "{:.3f}")
      for f in (FERN4, "fern_llff_paper_cuda_h100_ptp5000.json") for m in ("psnr", "ssim")],
    *[("README.md", f"{s}_synth_gnfr_gnt_cpu_s100.json", f"methods/{m}/inputs/{k}", "{:.2f}")
      for s in ("kermit", "cyprus") for m in ("gnfr", "gnt", "input")
      for k in ("psnr_flare", "psnr")],
    *[("docs/eval.md", f"{s}_synth_gnfr_gnt_cpu_s42.json", f"methods/{m}/heldout/{k}", f)
      for s in ("kermit", "cyprus") for m in ("gnfr", "gnt")
      for k, f in (("psnr", "{:.2f}"), ("ssim", "{:.3f}"))],
    *[("docs/eval.md", f"variant_regions_{s}_s42.json", k, "{:.2f}")
      for s in ("kermit", "cyprus") for k in ("psnr_gnfr", "psnr_gnt")],
    *[("docs/eval.md", f"{s}_synth_gnfr_gnt_cpu_s36.json", f"methods/{m}/heldout/{k}", f)
      for s in ("kermit", "cyprus") for m in ("gnfr", "gnt")
      for k, f in (("psnr", "{:.2f}"), ("ssim", "{:.3f}"))],
    *[("docs/eval.md", f"variant_regions_{s}_s36.json", k, "{:.2f}")
      for s in ("kermit", "cyprus") for k in ("psnr_gnfr", "psnr_gnt")],
    *[("docs/eval.md", f"{s}_synth_gnfr_gnt_cpu_s31.json", f"methods/{m}/heldout/{k}", f)
      for s in ("kermit", "cyprus") for m in ("gnfr", "gnt")
      for k, f in (("psnr", "{:.2f}"), ("ssim", "{:.3f}"))],
    *[("docs/eval.md", f"{s}_synth_gnfr_gnt_cpu_s31.json", "methods/photos/inputs/psnr_flare",
       "{:.2f}") for s in ("kermit", "cyprus")],
    # docs/eval.md: how far a seed moves the photo rule's arms (seventy-third session)
    *[("docs/eval.md", f"photo_spread_{a}_s73.json", f"per_scene/{sc}/{k}/sd", "{:.3f}")
      for a in ("s29_frc", "s26_Mp", "s69_sh") for sc in ("sceaux", "et", "lund")
      for k in ("psnr_flare", "held")],
    *[("docs/eval.md", f"photo_spread_{a}_s73.json", f"se_mean_difference/{n}/{k}", "{:.3f}")
      for a in ("s29_frc", "s26_Mp", "s69_sh") for n in ("2", "4")
      for k in ("psnr_flare", "held")],
    *[("docs/eval.md", "photo_null_judge_s73.json", p, "{:+.3f}")
      for p in ("mean/psnr_flare", "per_scene/lund/psnr_flare")],
    # the FMG card: the shipped file's numbers
    *[("gnfr/weights/fmg.md", "mask_time_cpu_M.json", f"rows/{i}/median_s_per_view", "{:.3f}")
      for i in (0, 1)],
    *[("gnfr/weights/fmg.md", "fmg_dev_per_kind_M_rays.json", f"kinds/{k}/weights/{m}", "{:.3f}")
      for k in ("starburst", "ghosts", "streaks", "glare", "scatter")
      for m in ("IoU_flare", "mIoU", "mAcc")],
    *[("gnfr/weights/fmg.md", "mask_dev_scenes_M.json", f"rows/{i}/flare_iou", "{:.3f}")
      for i in (3, 4, 5)],
    *[("gnfr/weights/fmg.md", "mask_test_sample_small_vs_M.json", f"rows/{i}/flare_iou",
       "{:.3f}") for i in (1, 3)],
    ("gnfr/weights/fmg.md", "mask_time_cpu_L.json", "rows/1/median_s_per_view", "{:.3f}"),
    *[("gnfr/weights/fmg.md", "fmg_photo_judge_Mprime_all.json", f"mean/{m}", f)
      for m, f in (("psnr_flare", "{:+.2f}"), ("psnr", "{:+.2f}"), ("ssim", "{:.4f}"),
                   ("held", "{:.2f}"))],
    *[("gnfr/weights/fmg.md", f, f"mean/{m}", "{:.2f}")
      for f in ("sample_oneshot_cpu_s26_fmgM.json", "sample_oneshot_cpu_s17_dilate0.json")
      for m in ("psnr", "psnr_flare")],
    *[("docs/eval.md", f"fmg_fair_{s}_{arm}{sd}.json", "methods/gnfr/inputs/psnr_flare",
       "{:.2f}") for s in ("et", "lund") for arm in ("shipped", "J") for sd in ("", "_s1")],
    # docs/eval.md, "The README's results, row by row": the current rows' extra figures
    *[("docs/eval.md", "kermit_synth_quick_cpu_s27_Mprime.json", f"methods/{m}/inputs/ssim",
       "{:.3f}") for m in ("gnfr", "input")],
    ("docs/eval.md", "kermit_synth_quick_cpu_s27_Mprime.json", "mask_scores/iou_flare", "{:.3f}"),
    *[("docs/eval.md", "kermit_synth_quick_cpu_fmg_masks_cut075.json", f"methods/gnfr/inputs/{k}",
       "{:.2f}") for k in ("psnr_flare", "psnr")],
    *[("docs/eval.md", "sample_oneshot_cpu_s17_dilate0.json", f"mean/{m}", "{:.2f}")
      for m in ("psnr_flare", "psnr")],
    *[("docs/eval.md", "fern_llff_quick_cpu_w42250_random_sources.json",
       f"clean/methods/gnfr_{fill}/heldout/{m}", "{:.2f}" if m == "psnr" else "{:.3f}")
      for fill in ("hybrid", "network") for m in ("psnr", "ssim")],
    *[("docs/presets.md", f"finetune_ab_lr_scale_dev_{scene}.json", f"{row}/{m}",
       "{:.3f}" if m == "heldout_ssim" else "{:.2f}")
      for scene in ("et", "sceaux") for row in ("base", "lr_scale-0")
      for m in ("heldout_psnr", "heldout_ssim", "inputs_psnr", "flare_region_psnr")],
    *[("docs/presets.md", "finetune_ab_random_sources_dev_et_clean.json", f"{row}/heldout_{m}",
       "{:.2f}" if m == "psnr" else "{:.3f}")
      for row in ("base", "random_sources-true") for m in ("psnr", "ssim")],
    *[(page, f, f"clean/methods/gnfr_{fill}/heldout/{m}", "{:.2f}" if m == "psnr" else "{:.3f}")
      for page, files in (("README.md", ("fern_llff_quick_cpu_s90.json",)),
                          ("docs/goals.md", ("fern_llff_quick_cpu_s50.json",
                                             "fern_llff_quick_cpu_s51_agree.json")),
                          ("docs/eval.md", ("fern_llff_quick_cpu_s50.json",
                                            "fern_llff_quick_cpu_s51_agree.json")),
                          ("gnfr/weights/gnfr.md", ("fern_llff_quick_cpu_s50.json",
                                                    "fern_llff_quick_cpu_s51_agree.json",
                                                    "fern_llff_quick_cpu_s42.json",
                                                    "fern_llff_quick_cpu_s30_ds0.json",
                                                    "fern_llff_quick_cpu_s29_frc.json",
                                                    "fern_llff_quick_cpu_s29_base.json")))
      for f in files for fill in ("hybrid", "network") for m in ("psnr", "ssim")],
    *[("docs/eval.md", FERN4, f"clean/methods/gnfr_{fill}/heldout/{m}",
       "{:.2f}" if m == "psnr" else "{:.3f}")
      for fill in ("hybrid", "network") for m in ("psnr", "ssim")],
    *[("README.md", "sample_oneshot_cpu_w42250.json", f"mean/{m}", "{:.2f}")
      for m in ("psnr_flare_input", "psnr_input")],
    *[(page, f, f"flare/methods/{m}/inputs/psnr_flare", "{:.2f}")
      for m in ("gnfr", "gnt", "input")
      for page, f in (("README.md", "fern_llff_quick_cpu_s100.json"),
                      ("docs/eval.md", "fern_llff_quick_cpu_s50.json"))],
    *[("docs/eval.md", "kermit_synth_quick_cpu_fmg_masks_cut075.json",
       f"methods/{m}/inputs/{k}", "{:.2f}")
      for m in ("gnfr", "input") for k in ("psnr_flare", "psnr")],
    *[(page, f"fern_llff_paper_cuda_{gpu}.json",
       f"clean/methods/gnfr_{fill}/heldout/{m}", "{:.2f}" if m == "psnr" else "{:.3f}")
      for page, gpu in (("README.md", "h200_s78"), *(("docs/goals.md", g) for g in
                                                      ("h100_ptp5000", "h200_s77", "h200_s78")))
      for fill in ("hybrid", "network") for m in ("psnr", "ssim")],
    *[(page, "bench_paper_cuda_h200_s77.json", f"results/cuda/train/{mode}/it_per_s", "{:.2f}")
      for page in ("docs/presets.md", PERF) for mode in ("end_to_end", "cached")],
    *[(page, "bench_paper_cuda_h200_s77.json", f"results/cuda/render/{size}/{path}/s_per_frame",
       "{:.2f} s") for page, path in ((PERF, "fast"), ("docs/presets.md", "fast"),
                                      ("docs/presets.md", "reference"))
      for size in ("504x378", "1008x756")],
    ("docs/presets.md", "bench_paper_cuda_h200_s77.json", "results/cuda/train/reference/it_per_s",
     "{:.2f}"),
    *[(page, f"bench_paper_cuda_h100{sfx}.json", f"results/cuda/train/{mode}/it_per_s", "{:.2f}")
      for page in ("docs/presets.md", PERF) for sfx in ("", "_s35")
      for mode in ("end_to_end", "cached")],
    *[("docs/presets.md", f"bench_{p}_cuda_h100_s35.json", "results/cuda/train/reference/it_per_s",
       "{:.2f}") for p in ("paper", "quick")],
    ("docs/presets.md", "bench_quick_cuda_h100_s35.json", "results/cuda/train/end_to_end/it_per_s",
     "{:.2f}"),
    *[(page, "bench_paper_cuda_h100_s35.json", f"results/cuda/render/{size}/fast/s_per_frame",
       "{:.2f} s") for page in (PERF, "docs/presets.md") for size in ("504x378", "1008x756")],
    *[(page, "bench_paper_cuda_h100.json", f"results/cuda/render/{size}/fast/s_per_frame",
       "{:.2f} s") for page in (PERF, "docs/presets.md")
      for size in ("504x378", "1008x756")],
    *[("docs/presets.md", f"bench_{p}_cuda_h100{sfx}.json", f"results/cuda/train/{mode}/it_per_s",
       "{:.2f}") for p, sfx, mode in (("paper", "", "reference"), ("paper", "_1008", "end_to_end"),
                                      ("paper", "_1008", "reference"), ("quick", "", "end_to_end"),
                                      ("quick", "", "reference"))],
    ("docs/presets.md", "render_compile_cuda_h100_paper.json", "speedup", "{:.2f}x"),
    (PERF, "sample_oneshot_cpu_idle_6c828cd.json", "stages/finetune/seconds", "{:.1f}"),
    (PERF, "sample_oneshot_cpu_s13_5d4b156.json", "stages/finetune/seconds", "{:.1f}"),
    (PERF, "sample_oneshot_cpu_s13_5d4b156.json", "stages/render:interpolate/seconds",
     "{:.1f}"),
    (PERF, "sample_oneshot_cpu_s13_5d4b156.json", "mean/psnr", "{:.2f}"),
    (PERF, "sample_oneshot_cpu_s13_5d4b156.json", "mean/psnr_flare", "{:.2f}"),
    (PERF, "sample_oneshot_cpu_idle_6c828cd.json", "stages/render:interpolate/seconds",
     "{:.1f}"),
    *[("docs/eval.md", f"fill_flare_layer_dev_{scene}_network.json", f"rows/{row}/psnr_flare",
       "{:.2f}") for scene in ("sceaux", "et")
      for row in ("network", "hybrid_guided_support2")],
    *[("docs/eval.md", "sample_oneshot_cpu_s17_dilate0.json", f"mean/{m}", "{:.2f}")
      for m in ("psnr_flare", "psnr")],
    *[("docs/eval.md", "sample_oneshot_cpu_s29_frc.json", f"mean/{m}", "{:.2f}")
      for m in ("psnr_flare", "psnr")],
    *[(page, "sample_oneshot_cpu_s36_ghosts.json", f"mean/{m}", "{:.2f}")
      for page, ms in (("README.md", ("psnr_flare_input", "psnr_input")),
                       ("docs/eval.md", ("psnr_flare", "psnr"))) for m in ms],
    *[(page, "bench_fill_cpu_lund_s36.json",
       f"results/cpu/render_workspace/rows/{i}/s_per_frame", "{:.2f} s")
      for page in (PERF, "docs/options.md") for i in (1, 3)],
    *[(PERF, "bench_fill_cpu_lund_s36.json",
       f"results/cpu/render_workspace/rows/{i}/s_per_frame", "{:.2f} s") for i in (0, 2)],
    *[("docs/depth.md", "stereo_time_cpu_lund_s37_after.json", path, "{:.2f} s")
      for path in ("depth_stage/seconds_per_view", "fill/0/seconds_per_frame",
                   "fill/1/seconds_per_frame")],
    *[(PERF, f"stereo_time_cpu_lund_s37_{w}.json", path, "| {:.2f} s")
      for w in ("before", "after", "final") for path in ("depth_stage/seconds_per_view",
                                                "fill/0/seconds_per_frame",
                                                "fill/1/seconds_per_frame")],
    *[(PERF, f"bench_fill_cpu_lund_s37_{w}.json",
       f"results/cpu/render_workspace/rows/{i}/s_per_frame", "{:.2f} s")
      for w in ("before", "after") for i in range(4)],
    *[(PERF, "sample_oneshot_cpu_s37.json", f"stages/{st}/seconds", fmt)
      for st, fmt in (("mask", "-> {:.1f} s"), ("depth", "-> {:.1f} s"),
                      ("render:inputs", "-> {:.1f} s"), ("render:interpolate", "-> {:.1f} s"),
                      ("finetune", "took {:.1f} s"))],
    *[(PERF, f, f"stages/{st}/seconds", fmt)
      for f in ("sample_oneshot_cpu_s40.json", "sample_oneshot_cpu_s40b.json")
      for st, fmt in (("finetune", "fine-tuning {:.1f} s"), ("render:interpolate",
                                                             "frames {:.1f} s"))],
    *[(PERF, "sample_oneshot_cpu_s36_ghosts.json", f"stages/{st}/seconds", "{:.1f} s ->")
      for st in ("mask", "depth", "render:inputs", "render:interpolate")],
    *[(PERF, "clean_capture_lund_s37.json", f"stages/{st}/seconds", "| {:.1f} |")
      for st in ("pose", "mask", "depth", "finetune", "render:inputs", "render:interpolate")],
    (PERF, "clean_capture_lund_s37.json", "stages/depth/sweeps_from_mask_stage",
     "took {} of its"),
    *[(PERF, "clean_capture_lund_s98.json", f"stages/{st}/seconds", "| {:.1f} |")
      for st in ("pose", "mask", "depth", "finetune", "render:inputs", "render:interpolate")],
    *[(PERF, "clean_capture_lund_s36.json", f"stages/{st}/seconds", "{:.1f}")
      for st in ("pose", "mask", "depth", "finetune", "render:inputs", "render:interpolate")],
    *[(PERF, f"crosscheck_time_cpu_et_s36_{w}.json", "rows/ghost_views/seconds_per_view",
       fmt) for w, fmt in (("before", "{:.2f} s per view"), ("after", "{:.2f} s after"))],
    *[(PERF, "sample_oneshot_cpu_s36_ghosts.json", p, "{:.1f} s") for p in
      ("stages/mask/seconds", "stages/finetune/seconds", "stages/render:interpolate/seconds")],
    *[("README.md", "sample_oneshot_cpu_s26_fmgM.json", f"mean/{m}", "{:.2f}")
      for m in ("psnr_flare_input", "psnr_input")],
    *[("docs/eval.md", "sample_oneshot_cpu_s26_fmgM.json", f"mean/{m}", "{:.2f}")
      for m in ("psnr_flare", "psnr")],
    (PERF, "sample_oneshot_cpu_s26_fmgM.json", "stages/mask/seconds", "{:.1f}"),
    *[(PERF, "sample_oneshot_cpu_s29_frc.json", p, "{:.1f} s") for p in
      ("stages/finetune/seconds", "stages/render:interpolate/seconds")],
    *[(PERF, "sample_oneshot_cpu_s30_ds0.json", p, "{:.1f} s") for p in
      ("stages/finetune/seconds", "stages/render:interpolate/seconds")],
    *[(PERF, "sample_oneshot_cpu_s29_5660997.json", p, "{:.1f} s") for p in
      ("stages/finetune/seconds", "stages/render:interpolate/seconds")],
    *[(PERF, "sample_oneshot_cpu_s29_5660997.json", f"mean/{m}", "{:.2f}")
      for m in ("psnr_flare", "psnr")],
    ("README.md", FERN, "published/0/psnr", "{:.2f}"),
    ("README.md", FERN, "flare/methods/input/inputs/psnr_flare", "{:.2f}"),
    ("README.md", SAMPLE, "mean/psnr_flare_input", "{:.2f}"),
    ("README.md", SAMPLE, "mean/psnr_input", "{:.2f}"),
    (PERF, SAMPLE, "stages/depth/seconds", "| depth | {:.1f} |"),
    (PERF, SAMPLE, "stages/finetune/seconds", "{:.1f}"),
    (PERF, SAMPLE, "stages/render:interpolate/seconds", "{:.1f}"),
    ("README.md", SAMPLE, "video/frames", "{} frames"),
    ("docs/depth.md", "fill_ablation_dev_sceaux.json",
     "rows/hybrid_guided_support1/psnr_flare", "{:.2f}"),
    ("docs/depth.md", "fill_ablation_dev_et.json", "rows/hybrid_unguided/psnr_flare",
     "{:.2f}"),
    *[("docs/depth.md", f"novel_loo_dev_{scene}_{fill}.json", m, "{:.2f}" if m == "psnr"
       else "{:.3f}") for scene in ("sceaux", "et") for fill in ("hybrid", "network")
      for m in ("psnr", "ssim")],
    # the flare layer (sixth session): the render stage's rows and the variants. sceaux's
    # pasted fill scores 18.215 in the flare region, which "{:.2f}" writes 18.21: the figure of
    # docs/depth.md's "Measured on the development scenes" (the same render); the history's
    # table writes it 18.22
    *[("docs/depth.md" if (scene, row, m) == ("sceaux", "hybrid_no_flare_layer", "psnr_flare")
       else "docs/history/fill.md", f"fill_flare_layer_dev_{scene}.json", f"rows/{row}/{m}",
       "{:.3f}" if m == "ssim" else "{:.2f}") for scene in ("sceaux", "et", "sceaux_streaks")
      for row in ("hybrid_guided_support2", "hybrid_no_flare_layer")
      for m in ("psnr_flare", "psnr", "ssim")],
    *[("docs/presets.md", f"finetune_ab_random_sources_dev_{scene}_flare_layer_{arm}.json",
       f"rows/hybrid_guided_support2/{m}", "{:.2f}") for scene in ("sceaux", "et")
      for arm in ("base", "random_sources-true") for m in ("psnr_flare", "psnr")],
    # the final bench run (README tables) and the earlier one quoted for the drift
    *[(PERF, "bench_cpu.json", f"results/cpu/{path}", fmt) for path, fmt in (
        ("train/end_to_end/it_per_s", "{:.2f}"), ("train/cached/it_per_s", "{:.2f}"),
        ("train/reference/it_per_s", "{:.2f}"), ("render/504x378/fast/s_per_frame", "{:.1f}"),
        ("render/1008x756/fast/s_per_frame", "{:.1f}"))],
    *[(PERF, "bench_cpu_c426ab3.json", f"results/cpu/{path}", fmt) for path, fmt in (
        ("train/end_to_end/it_per_s", "{:.2f}"), ("train/cached/it_per_s", "{:.2f}"),
        ("render/504x378/fast/s_per_frame", "{:.1f} s"))],
    (PERF, "render_compile_cpu.json", "speedup", "{:.2f}x faster"),
    (PERF, "render_compile_cpu.json", "eager_s", "{:.2f} s eager"),
    (PERF, "render_compile_cpu.json", "compiled_s", "{:.2f} s compiled"),
    (PERF, "render_compile_cpu.json", "compile_s", "{:.0f} s of compiling"),
    # the frames in two processes (forty-sixth session): rows are (chunk, workers)
    *[(PERF, f"render_speed_cpu_{n}f_s46.json", f"rows/{i}/s_per_frame",
       "| {:.2f} s per frame |") for n in (48, 12) for i in (0, 1)],
    (PERF, "render_speed_cpu_12f_s46.json", "rows/2/s_per_frame", "({:.2f} s per frame"),
    (PERF, "render_speed_cpu_12f_s46.json", "rows/3/s_per_frame", "({:.2f} s both)"),
    (PERF, "render_speed_cpu_48f_s46.json", "rows/1/pixels_differing", "{} of the 48 frames'"),
    (PERF, "render_speed_cpu_12f_s46.json", "rows/1/pixels_differing", "({} of\nthe 12"),
    *[("docs/presets.md", "finetune_ab_dropout_dev_et.json", f"{row}/{m}",
       "{:.3f}" if m.endswith("ssim") else "{:.2f}")
      for row in ("base", "dropout-0.1")
      for m in ("heldout_psnr", "heldout_ssim", "inputs_psnr", "flare_region_psnr")],
    *[("docs/presets.md", f"finetune_ab_random_sources_dev_{scene}.json", f"{row}/{m}",
       "{:.3f}" if m.endswith("ssim") else "{:.2f}")
      for scene in ("sceaux", "et") for row in ("base", "random_sources-true")
      for m in ("heldout_psnr", "heldout_ssim", "inputs_psnr", "flare_region_psnr")],
    *[("docs/eval.md", f"finetune_ab_seed_{f}.json", f"{row}/{m}",
       "{:.3f}" if m == "heldout_ssim" else "{:.2f}")
      for f, row in (("1_dev_et", "seed-1"), ("2_dev_et", "seed-2"), ("1_dev_et", "base"),
                     ("1_dev_sceaux", "seed-1"), ("1_dev_sceaux", "base"))
      for m in ("heldout_psnr", "heldout_ssim", "inputs_psnr", "flare_region_psnr")],
    *[("docs/presets.md", f"finetune_ab_ray_sampling_edges_dev_{scene}.json", f"{row}/{m}",
       "{:.3f}" if m == "heldout_ssim" else "{:.2f}")
      for scene in ("et", "sceaux") for row in ("base", "ray_sampling-edges")
      for m in ("heldout_psnr", "heldout_ssim", "inputs_psnr", "flare_region_psnr")],
    *[("docs/presets.md", f"finetune_ab_lr_schedule_cosine_dev_{scene}.json", f"{row}/{m}",
       "{:.3f}" if m == "heldout_ssim" else "{:.2f}")
      for scene in ("et", "sceaux") for row in ("base", "lr_schedule-cosine")
      for m in ("heldout_psnr", "heldout_ssim", "inputs_psnr", "flare_region_psnr")],
]


@pytest.mark.parametrize("page, file, path, fmt", CHECKS,
                         ids=[f"{c[0]}:{c[1]}:{c[2]}" for c in CHECKS])
def test_page_quotes_its_result_file(page, file, path, fmt):
    assert_quoted(page, file, path, fmt)


@pytest.mark.parametrize("name", ["x1", "x2"])
def test_performance_render_times_match(name):
    text = (REPO / "docs" / "performance.md").read_text()
    net, hyb = fill_row(name, "network"), fill_row(name, "hybrid")
    row = (f"| {net['size'][0]}x{net['size'][1]} | {net['s_per_frame']:.1f} s | "
           f"{hyb['s_per_frame']:.1f} s | {net['s_per_frame'] / hyb['s_per_frame']:.0f}x |")
    assert net["size"] == hyb["size"] and row in text, row


def test_every_result_file_is_quoted_or_listed():
    """No orphan result files: each is named in docs/results/README.md or a page."""
    pages = "".join((REPO / p).read_text() for p in ("README.md", "docs/eval.md",
                                                     "docs/depth.md", "docs/results/README.md",
                                                     "docs/options.md", "docs/performance.md",
                                                     "gnfr/weights/gnfr.md",
                                                     "docs/history/gnfr.md",
                                                     "docs/history/fill.md",
                                                     "docs/history/eval.md"))
    for f in RESULTS.glob("*.json"):
        assert f.name in pages, f"{f.name} is quoted nowhere"


@pytest.mark.parametrize("scene, row", [
    ("sceaux_synth", "flared input"), ("sceaux_synth", "scale_0.06"),
    ("sceaux_synth", "scale_0.12 (default)"), ("et_synth", "flared input"),
    ("et_synth", "scale_0.12 (default)"), ("sceaux_ghosts", "flared input"),
    ("sceaux_ghosts", "scale_0.12 (default)"), ("sceaux_ghosts", "norm_0.12")])
def test_depth_doc_quotes_the_flare_layer_variants(scene, row):
    """docs/history/fill.md's flare-layer paragraph and table (moved from docs/depth.md)
    against the variants file (keyed by the scene folders' paths, so not reachable by the
    '/'-separated paths above)."""
    scenes = result("flare_layer_variants_dev.json")["scenes"]
    (rows,) = [v["rows"] for k, v in scenes.items() if Path(k).name == scene]
    value = f"{rows[row]['psnr_flare']:.2f}"
    assert value in (REPO / "docs" / "history" / "fill.md").read_text(), (scene, row, value)


def test_max_flare_note_numbers_agree_with_their_runs():
    """`--max-flare 0.15` on lund_k4 (twenty-eighth session): the seed means in the history
    and the two differences the README quotes."""
    history = page_text("docs/history/fmg.md")

    def means(arm):
        rows = [result(f"fmg_s28_{arm}_fair_lund_k4_s{s}.json")
                for s in (0, 1, 2)]
        m = {k: sum(r["inputs"][k] for r in rows) / 3 for k in ("psnr", "psnr_flare", "ssim")}
        m.update({f"held_{k}": sum(r["heldout"][k] for r in rows) / 3 for k in ("psnr", "ssim")})
        return m

    base, loose = means("Mp"), means("Mp_mf15")
    for m in (base, loose):
        row = (f"{m['psnr']:.2f} / {m['psnr_flare']:.2f} / {m['ssim']:.3f} | "
               f"{m['held_psnr']:.2f} / {m['held_ssim']:.3f}")
        assert row in history
    options = page_text("docs/options.md")
    for text in (history, options):
        assert f"{loose['held_psnr'] - base['held_psnr']:.2f} dB" in text
        assert f"{base['psnr_flare'] - loose['psnr_flare']:.2f} dB" in text


def test_crosscheck_photo_rule_numbers_agree_with_the_judge():
    """The crosscheck photo rule's table (history), its mean flare gain and cost (options
    page) and its cost (README)."""
    history = page_text("docs/history/fmg.md")
    readme = page_text("docs/options.md")
    res = result("fmg_photo_judge_crosscheck_s234.json")
    for d in (*res["per_scene"].values(), res["mean"]):
        cells = " / ".join(f"{d[k]:+.3f}" for k in ("psnr", "psnr_flare", "ssim", "held"))
        assert cells in history
    assert res["decision"] == "fails (a)" and "fails (a)" in history
    assert f"{res['mean']['psnr_flare']:+.3f} dB in the flare region" in readme
    cost = result("crosscheck_time_cpu_et.json")
    assert f"{cost['extra_seconds_per_view']:.1f} s more per view" in readme
    assert f"+{cost['extra_seconds_per_view']:.1f} s per view" in readme


def test_readme_sample_flare_gain_per_view():
    """The README: the sample's mean flare-region gain and its per-view range, from the run its
    Results table quotes (the hundredth session's); the README's notes until the
    ninety-second session (docs/eval.md) quoted the thirty-sixth session's run."""
    for f, text in (("sample_oneshot_cpu_s100_head.json", page_text("README.md")),
                    ("sample_oneshot_cpu_s36_ghosts.json", readme_notes())):
        views = result(f)["views"]
        gains = [v["psnr_flare"] - v["psnr_flare_input"] for v in views.values()]
        assert len(gains) == 8 and min(gains) > 0, f
        assert f"{sum(gains) / len(gains):.2f} dB closer to the truth" in text, f
        assert f"+{min(gains):.2f}" in text and f"+{max(gains):.2f} dB" in text, f


def test_full_res_colour_rule_numbers_agree_with_the_judge():
    """docs/presets.md's table of the full-size colours rule is the judge's file, the judge
    recomputes from the committed runs, and the baseline repeat reproduces its file."""
    page = page_text("docs/presets.md")
    res = result("fmg_photo_judge_full_res_colour_s234.json")
    assert res["rule"] == "novel" and res["decision"] == "passes"
    for d in (*res["per_scene"].values(), res["mean"]):
        cells = " | ".join(f"{d[k]:+.3f}" for k in ("psnr", "psnr_flare", "ssim", "held"))
        assert cells in page
    mod = load_benchmark("fmg_photo_ab")
    again = mod.judge(RESULTS, "s29_frc", "s26_Mp", ["sceaux", "et", "lund"], [2, 3, 4],
                      rule="novel")
    assert again["mean"] == pytest.approx(res["mean"]) and again["decision"] == res["decision"]
    rep = result("fmg_s29_repro_fair_et_s2.json")
    old = result("fmg_s26_Mp_fair_et_s2.json")
    assert rep["heldout"]["psnr"] == old["heldout"]["psnr"]
    assert rep["inputs"]["psnr_flare"] == old["inputs"]["psnr_flare"]


def test_depth_next_quotes_the_network_fill_seed_means():
    """docs/depth.md "Next": GN-FR alone against the hybrid fill on the full-size-colour
    models, seed means per development scene, from the committed runs."""
    page = page_text("docs/depth.md")

    def mean(prefix, scene, key):
        return sum(result(f"{prefix}_{scene}_s{s}.json")
                   ["heldout"][key] for s in (2, 3, 4)) / 3

    for scene in ("sceaux", "et", "lund"):
        net, hyb = ("{:.2f} / {:.3f}".format(mean(p, scene, "psnr"), mean(p, scene, "ssim"))
                    for p in ("novel_fill_network_s29_frc", "fmg_s29_frc_fair"))
        assert f"{net} against {hyb}" in page, (scene, net, hyb)


def test_full_res_colour_speed_numbers():
    """docs/presets.md's speed of the two colour sizes at the decode default."""
    r = result("full_res_colour_speed_cpu_lund1062.json")
    page = page_text("docs/presets.md")
    assert (f"{r['full']['it_s']:.2f} steps/s with full-size colours against "
            f"{r['quarter']['it_s']:.2f} with quarter-size ones, {100 * r['slower']:.0f} % "
            "slower") in page
    c = result("full_res_colour_speed_cpu_lund1062_cached.json")
    assert (f"{c['full']['it_s']:.2f} against {c['quarter']['it_s']:.2f} steps/s, "
            f"{100 * c['slower']:.0f} % slower") in page
    w, h = r["full"]["image_size"]
    assert f"{w}x{h}" in page
    sh = result("full_res_colour_speed_cpu_lund1062_shared.json")
    assert (f"{sh['full']['it_s']:.2f} against {sh['quarter']['it_s']:.2f} steps/s, "
            f"{100 * sh['slower']:.0f} % slower") in page
    o = json.loads((RESULTS / "full_res_colour_speed_cpu_lund1062_shared_vs_cached.json"
                    ).read_text())
    assert f"{100 * o['faster']:.0f} % faster" in page
    assert f"({o['full']['it_s']:.2f} against {o['full_other_code']['it_s']:.2f} steps/s" in page
    options = page_text("docs/options.md")
    assert f"CPU fine-tune {100 * sh['slower']:.0f} % slower" in options


def test_fern_gain_of_full_size_colours():
    """docs/eval.md: fern's gain from full-size colours per fill, from the two committed
    runs."""
    def psnr(f, fill):
        return result(f)["clean"]["methods"][f"gnfr_{fill}"][
            "heldout"]["psnr"]
    page = page_text("docs/eval.md")
    gains = [psnr("fern_llff_quick_cpu_s29_frc.json", f)
             - psnr("fern_llff_quick_cpu_s29_base.json", f) for f in ("hybrid", "network")]
    assert (f"+{gains[0]:.2f} dB with the default hybrid fill and +{gains[1]:.2f} dB with "
            "GN-FR alone") in page


def test_sample_scores_unchanged_by_whole_ray_novel_frames():
    """docs/performance.md says the one-shot with whole-ray novel frames kept the sample's
    scores to the last digit: the de-flared photos' means are the twenty-ninth session's."""
    new = result("sample_oneshot_cpu_s30_ds0.json")["mean"]
    old = result("sample_oneshot_cpu_s29_frc.json")["mean"]
    assert new == old


def test_sample_scores_of_the_fortieth_sessions_fresh_clone_are_the_thirty_seventh_s():
    """docs/performance.md says the fresh clone's main job gave every score of the
    thirty-seventh session's run to the last digit: per view and on the mean."""
    old = result("sample_oneshot_cpu_s37.json")
    for f in ("sample_oneshot_cpu_s40.json", "sample_oneshot_cpu_s40b.json"):
        new = result(f)
        assert new["mean"] == old["mean"] and new["views"] == old["views"]


@pytest.mark.parametrize("width", [504, 1008])
def test_performance_whole_ray_frame_times_match(width):
    """docs/performance.md's table of the video frames with the whole-ray default, and the
    README's 504 px figures, are bench_fill_cpu_s30.json's."""
    rows = result("bench_fill_cpu_s30.json")["results"]["cpu"]["render_workspace"]["rows"]
    by = {r["fill"]: r for r in rows if r["size"][0] == width}
    net, hyb = by["network"], by["hybrid"]
    row = (f"| {net['size'][0]}x{net['size'][1]} | {net['s_per_frame']:.1f} s | "
           f"{hyb['s_per_frame']:.1f} s | {net['s_per_frame'] / hyb['s_per_frame']:.0f}x |")
    assert row in (REPO / "docs" / "performance.md").read_text(), row
    if width == 504:  # the README: the sample one-shot's frames now (the forty-sixth and
        # forty-seventh sessions' runs), in the forty-fifth session and before its fill,
        # GN-FR alone
        summary = readme_performance()
        def per_frame(name):
            return result(name)["stages"]["render:interpolate"]["seconds"] / 48
        now, s45, before = (per_frame(f) for f in (
            "sample_oneshot_cpu_s46.json", "sample_oneshot_cpu_s45.json",
            "sample_oneshot_cpu_s45_before.json"))
        slow = max(per_frame(f"sample_oneshot_cpu_s47_{c}.json") for c in ("f70850f", "head"))
        assert f"video frames ({now:.1f}-{slow:.1f} s each at 512x336" in summary
        assert f"{s45:.1f} s on the Intel Xeon of the forty-fifth session" in summary
        assert (f"{before:.1f} s before it there; {net['s_per_frame']:.1f} s with GN-FR "
                "alone") in summary


def test_mask_kinds_pooled_summary_is_the_card_and_history():
    """The FMG card's and history's per-kind numbers at the photos' scale are
    mask_kind_scenes.py's summary of the three committed builds."""
    mk = load_benchmark("mask_kind_scenes")
    files = ("mask_dev_kinds_S2.json", "mask_dev_kinds_M_s32.json", "mask_dev_kinds_M_s33.json")
    res = mk.summary([result(f)["rows"] for f in files],
                     "fmg.safetensors@1")
    saved = result("mask_kinds_summary_M_s31_33.json")
    assert {k: v["mean"] for k, v in res["kinds"].items()} == {
        k: v["mean"] for k, v in saved["kinds"].items()}
    cells = ", ".join(f"{k} {res['kinds'][k]['mean']:.3f}"
                      for k in ("starburst", "ghosts", "streaks", "glare", "scatter"))
    for page in ("gnfr/weights/fmg.md", "docs/history/fmg.md"):
        assert cells in " ".join((REPO / page).read_text().split()), page


def test_variant_regions_numbers_in_eval_md():
    """docs/eval.md's split of the flare region (the photos' share, each network's PSNR on
    the rest) is variant_regions.py's files."""
    text = page_text("docs/eval.md")
    k, c = (result(f"variant_regions_{s}_s31.json")
            for s in ("kermit", "cyprus"))
    assert (f"{100 * k['identical_share']:.1f} % (kermit) and {100 * c['identical_share']:.1f} %"
            " (cyprus)") in text
    for r in (k, c):
        assert f"{r['psnr_gnfr']:.2f} against {r['psnr_gnt']:.2f} dB" in text


def test_consistency_planes_known_depth_is_its_records():
    """The known depth of each arm in docs/history/fill.md's consistency-in-planes table, and
    lund's pair in docs/depth.md, are the depth stage's records."""
    arms = result("depth_consistency_planes_coverage_dev.json")["arms"]
    pct = {k: f"{100 * v['coverage']:.1f} %" for k, v in arms.items()}
    hist = page_text("docs/history/fill.md")
    for sc, name in (("sceaux", "sceaux_castle"), ("et", "et"), ("lund", "lund")):
        cell = f"| {name} | {pct[sc + '_base']} / {pct[sc + '_k1']} |"
        assert cell in hist, cell
    depth = page_text("docs/depth.md")
    assert f"({pct['lund_base']} -> {pct['lund_k1']} at 504 px)" in depth
    options = page_text("docs/options.md")
    assert f"{pct['lund_k1']} of the pixels instead of {pct['lund_base']}" in options
