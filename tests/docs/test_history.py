"""The history pages' numbers (docs/history/*.md) agree with the result files they quote.

This file keeps the table ``CHECKS``: a number a history page quotes as it stands in a result
file. The tests that recompute a history's tables and verdicts are split by topic (ninety-fourth
session): test_history_masks.py and test_history_mask_rules.py (docs/history/fmg.md, the FMG
card's candidates, and the mask stage's rules and options), test_history_fill.py
(docs/history/fill.md, the depth and fill options), test_history_gnfr.py
(docs/history/gnfr.md and pose.md, the fine-tune and pretraining levers).
"""

from __future__ import annotations

import pytest

from tests.docs.numbers import (
    FERN,
    FERN2,
    FERN3,
    FERN18,
    SAMPLE,
    assert_quoted,
)

CHECKS = [
    # page, file, path, format
    # the FMG history, twenty-seventh session: the sample's per-view diagnosis
    *[("docs/history/fmg.md", f, f"views/{v}/psnr_flare", "{:.2f}")
      for f in ("sample_oneshot_cpu_s27_small_h0.json", "sample_cross_s27_Mmodel_smallmasks.json",
                "sample_cross_s27_smallmodel_Mmasks.json", "sample_oneshot_cpu_s26_fmgM.json",
                "sample_oneshot_cpu_s27_M_maxflare013.json")
      for v in ("DSC_6466", "DSC_6467", "DSC_6468", "DSC_6470", "DSC_6471", "DSC_6473",
                "DSC_6474", "DSC_6475")],
    *[("docs/history/fmg.md", f"fmg_s27_{arm}_fair_kermit_s0.json", p, "{:.2f}")
      for arm in ("small_h0", "Mp") for p in ("heldout/psnr",)],
    ("docs/history/fmg.md", "fmg_s27_small_h0_fair_kermit_s0.json", "inputs/psnr_flare",
     "{:.2f}"),
    *[("docs/history/fmg.md", f"fmg_s27_{arm}_fair_lund_k4_s0.json", p,
       "{:.4f}" if p.endswith("ssim") else "{:.2f}")
      for arm in ("small_h0", "Mp", "MpT")
      for p in ("inputs/psnr", "inputs/psnr_flare", "inputs/ssim", "heldout/psnr")],
    *[("docs/history/fmg.md", "mask_dev_rule_lund_k45.json", f"rows/{i}/flare_iou", "{:.3f}")
      for i in (2, 6)],
    *[("docs/history/fmg.md", "sample_oneshot_cpu_s17_J_fillholes.json", f"mean/{m}", "{:.2f}")
      for m in ("psnr", "psnr_flare")],
    *[("docs/history/fmg.md", "mask_dev_scenes_200px_fillholes.json", f"rows/{i}/flare_iou",
       "{:.3f}") for i in (3, 4, 5, 9, 10, 11)],
    *[("docs/history/fill.md", f"fill_feather_dev_{s}_s{sd}.json", f"rows/hybrid_feather_{d}/{m}",
       "{:.4f}" if m == "ssim" else "{:.2f}")
      for s in ("sceaux", "et", "lund") for sd in (0, 1) for d in ("0.01", "0.005", "0.02")
      for m in ("psnr", "psnr_flare", "ssim")],
    *[("docs/history/fill.md", f"sample_oneshot_cpu_s17_dilate{d}.json", f"mean/{m}", "{:.2f}")
      for d in ("0", "001") for m in ("psnr", "psnr_flare")],
    *[("docs/history/fmg.md", f"fmg_mask_shape_{s}.json", f"rows/{i}/scores/0/{m}", "{:.3f}")
      for s in ("sceaux", "et", "lund") for i in (0, 1) for m in ("recall", "light_left")],
    *[("docs/history/fmg.md", f"fmg_swap_{s}_{arm}_model.json", f"rows/{i}/psnr_flare", "{:.2f}")
      for s in ("sceaux", "et", "lund") for arm in ("shipped", "J") for i in (0, 1)],
    *[("docs/history/fmg.md", f"fmg_fair_{s}_{arm}_s1.json", "methods/gnfr/inputs/psnr_flare",
       "{:.2f}") for s in ("sceaux", "et", "lund") for arm in ("shipped", "J")],
    *[("docs/history/fmg.md", f"fmg_fillholes_{s}_J_s{sd}.json", "inputs/psnr_flare", "{:.2f}")
      for s in ("sceaux", "et", "lund") for sd in (0, 1)],
    *[("docs/history/fill.md", f"fill_dilate_dev_{s}_s{sd}.json", f"rows/hybrid_dilate_{d}/{m}",
       "{:.4f}" if m == "ssim" else "{:.2f}")
      for s in ("sceaux", "et", "lund") for sd in (0, 1) for d in ("0.01", "0.005", "0.0")
      for m in ("psnr", "psnr_flare", "ssim")],
    *[("docs/history/gnfr.md", f"pretrain_zero_shot_{s}_rs{step}.json", f"rows/{i}/{m}",
       "{:.2f}" if m == "psnr" else "{:.3f}")
      for s in ("sceaux", "et") for step, rows in ((80000, (0, 1)), (53000, (1,)))
      for i in rows for m in ("psnr", "ssim")],
    *[("docs/history/gnfr.md", f"pretrain_zero_shot_{s}_dropout55250.json", f"rows/{i}/{m}",
       "{:.2f}" if m == "psnr" else "{:.3f}")
      for s in ("sceaux", "et") for i in (0, 1) for m in ("psnr", "ssim")],
    *[("docs/history/eval.md", "sample_oneshot_cpu_w42250.json", f"mean/{m}", "{:.2f}")
      for m in ("psnr_flare", "psnr")],
    *[("docs/history/eval.md", "fern_llff_quick_cpu_w42250_flare_layer.json",
       f"clean/methods/gnfr_{fill}/heldout/{m}", "{:.2f}" if m == "psnr" else "{:.3f}")
      for fill in ("hybrid", "network") for m in ("psnr", "ssim")],
    *[("docs/history/eval.md", "fern_llff_quick_cpu_w42250_flare_layer.json",
       f"flare/methods/{m}/{part}", "{:.3f}" if part.endswith("ssim") else "{:.2f}")
      for m in ("gnfr", "gnt") for part in ("inputs/psnr_flare", "inputs/psnr",
                                             "heldout/psnr", "heldout/ssim")],
    *[("docs/history/eval.md", "kermit_synth_quick_cpu_fmg_masks_cut075.json",
       f"methods/{m}/inputs/ssim", "{:.3f}") for m in ("gnfr", "input")],
    ("docs/history/eval.md", "kermit_synth_quick_cpu_fmg_masks_cut075.json",
     "mask_scores/iou_flare", "{:.3f}"),
    *[("docs/history/eval.md", f"{scene}_quick_cpu_gnfr_vs_gnt_s13.json", f"methods/{m}/{part}",
       "{:.3f}" if part.endswith("ssim") else "{:.2f}")
      for scene in ("kermit_synth", "cyprus_truth") for m in ("gnfr", "gnt")
      for part in ("inputs/psnr_flare", "inputs/psnr", "heldout/psnr", "heldout/ssim")],
    *[("docs/history/eval.md", "kermit_synth_quick_cpu_fmg_masks_flare_layer.json",
       f"methods/gnfr/inputs/{k}", "{:.2f}") for k in ("psnr_flare", "psnr")],
    ("docs/history/eval.md", "kermit_synth_quick_cpu_fmg_masks_flare_layer.json",
     "methods/gnfr/inputs/ssim", "{:.3f}"),
    *[(page, f"pretrain_zero_shot_{scene}_frc56250.json", f"rows/{i}/{m}",
       "{:.2f}" if m == "psnr" else "{:.3f}")
      for page in ("docs/history/gnfr.md", "docs/history/eval.md") for scene in ("sceaux", "et")
      for i in (0, 1) for m in ("psnr", "ssim")],
    *[("docs/history/fill.md", f"depth_consistency_planes_inputs_dev_{sc}_{arm}.json",
       f"rows/hybrid_guided_support2/{m}", "{:.4f}" if m == "ssim" else "{:.3f}")
      for sc in ("sceaux", "et", "lund") for arm in ("base", "k1")
      for m in ("psnr_flare", "psnr", "ssim")],
    *[("docs/history/fill.md", f"depth_consistency_planes_heldout_dev_{sc}_{arm}.json",
       m, "{:.3f}" if m == "ssim" else "{:.2f} /")
      for sc in ("sceaux", "et", "lund") for arm in ("base", "k1") for m in ("psnr", "ssim")],
    *[("docs/history/eval.md", "sample_oneshot_cpu_cut075.json", f"mean/{m}", "{:.2f}")
      for m in ("psnr_flare", "psnr")],
    *[("docs/history/eval.md", f"sample_oneshot_cpu_s14_{c}.json", f"mean/{m}", "{:.2f}")
      for c in ("cc66234", "f408c72") for m in ("psnr_flare", "psnr")],
    *[("docs/history/eval.md", "sample_oneshot_cpu_w42250_flare_layer.json", f"mean/{m}", "{:.2f}")
      for m in ("psnr_flare", "psnr", "psnr_flare_input", "psnr_input")],
    *[("docs/history/fmg.md", "sample_oneshot_cpu_w42250_rays3.json", f"mean/{m}", "{:.2f}")
      for m in ("psnr_flare", "psnr")],
    ("docs/history/eval.md", FERN3, "clean/methods/gnfr_hybrid/heldout/psnr", "{:.2f}"),
    ("docs/history/eval.md", FERN3, "clean/methods/gnfr_hybrid/heldout/ssim", "{:.3f}"),
    ("docs/history/eval.md", FERN3, "clean/methods/gnfr_network/heldout/psnr", "{:.2f}"),
    ("docs/history/eval.md", FERN3, "clean/methods/gnfr_network/heldout/ssim", "{:.3f}"),
    ("docs/history/eval.md", FERN2, "clean/methods/gnfr_hybrid/heldout/psnr", "{:.2f}"),
    ("docs/history/eval.md", FERN2, "clean/methods/gnfr_hybrid/heldout/ssim", "{:.3f}"),
    ("docs/history/eval.md", FERN2, "clean/methods/gnfr_network/heldout/psnr", "{:.2f}"),
    ("docs/history/eval.md", FERN2, "clean/methods/gnfr_network/heldout/ssim", "{:.3f}"),
    ("docs/history/eval.md", FERN18, "clean/methods/gnfr_hybrid/heldout/psnr", "{:.2f}"),
    ("docs/history/eval.md", FERN18, "clean/methods/gnfr_network/heldout/ssim", "{:.3f}"),
    ("docs/history/eval.md", FERN, "clean/methods/gnfr_hybrid/heldout/psnr", "{:.2f}"),
    ("docs/history/eval.md", FERN, "clean/methods/gnfr_network/heldout/psnr", "{:.2f}"),
    ("docs/history/eval.md", FERN, "flare/methods/gnfr/inputs/psnr_flare", "{:.2f}"),
    ("docs/history/eval.md", FERN, "flare/methods/gnt/inputs/psnr_flare", "{:.2f}"),
    ("docs/history/eval.md", "sample_oneshot_cpu_w32500.json", "mean/psnr_flare", "{:.2f}"),
    ("docs/history/eval.md", "sample_oneshot_cpu_w32500.json", "mean/psnr", "{:.2f}"),
    ("docs/history/eval.md", SAMPLE, "mean/psnr_flare", "{:.2f}"),
    ("docs/history/eval.md", SAMPLE, "mean/psnr", "{:.2f}"),
    ("docs/history/eval.md", "fill_ablation_dev_sceaux.json",
     "rows/hybrid_guided_support2/psnr_flare", "{:.2f}"),
    ("docs/history/eval.md", "fill_ablation_dev_sceaux.json", "rows/network/psnr_flare", "{:.2f}"),
    ("docs/history/eval.md", "fill_ablation_dev_et.json", "rows/hybrid_guided_support2/psnr_flare",
     "{:.2f}"),
    ("docs/history/eval.md", "fill_ablation_dev_et.json", "rows/network/psnr_flare", "{:.2f}"),
    # render-time settings of a quick model (ninth session)
    *[("docs/history/fill.md", "render_settings_dev_s9.json", f"rows/{key}/{m}",
       "{:.2f}" if m == "psnr" else "{:.3f}")
      for key in [f"{sc}_{mode}_{tag}" for sc in ("et", "sceaux") for mode in ("held", "loo")
                  for tag in ("none", "n_sources8", "samples48", "network_scale0.5",
                              "network_scale1.0", "photo_sources6")]
      + [f"s25_{sc}_{mode}_{tag}" for sc in ("et", "sceaux") for mode in ("held", "loo")
         for tag in ("none", "network_scale0.5")]
      + [f"c_{m}_s{fs}_{mode}_{tag}" for m in ("etrs", "sceauxrs", "etclean")
         for fs in ("0.25", "1.0") for mode in ("held", "loo")
         for tag in ("none", "network_scale0.5")]
      for m in ("psnr", "ssim")],
    ("docs/history/gnfr.md", "pretrain_zero_shot_sceaux.json", "rows/0/psnr", "{:.2f}"),
    ("docs/history/gnfr.md", "pretrain_zero_shot_sceaux.json", "rows/1/psnr", "{:.2f}"),
    *[("docs/history/gnfr.md", f"pretrain_zero_shot_{scene}_w32500.json", f"rows/{i}/{m}",
       "{:.2f}" if m == "psnr" else "{:.3f}")
      for scene in ("sceaux", "et") for i in (0, 1) for m in ("psnr", "ssim")],
    *[("docs/history/fmg.md", f"fmg_dev_per_kind_{run}.json", f"kinds/{kind}/weights/{m}",
       "{:.3f}")
      for run in ("shipped", "s3_all_negatives", "s3_no_neon")
      for kind in ("starburst", "ghosts", "streaks", "glare", "scatter")
      for m in ("IoU_flare", "mIoU", "mAcc")],
    *[("docs/history/fmg.md", f"fmg_{part}_per_kind_{run}.json", f"kinds/{kind}/weights/IoU_flare",
       "{:.3f}")
      for part, runs in (("dev", ("s4_kind_share", "s4_dice", "w2400_rays", "s4_dice_rays")),
                         ("test", ("w2400", "w2400_rays", "s4_dice", "s4_dice_rays")))
      for run in runs for kind in ("starburst", "ghosts", "streaks", "glare", "scatter")],
    *[("docs/history/fmg.md", "mask_dev_scenes.json", f"rows/{i}/flare_iou", "{:.3f}")
      for i in range(8)],
    *[("docs/history/fmg.md", f"fmg_{part}_per_kind_w2400_rays_{run}.json",
       f"kinds/{kind}/weights/IoU_flare", "{:.3f}")
      for part, runs in (("dev", ("min2", "min3", "min3_opp8")), ("test", ("min3",)))
      for run in runs for kind in ("starburst", "ghosts", "streaks", "glare", "scatter")],
    *[("docs/history/fmg.md", "sample_oneshot_cpu_w42250_fmgD_rays.json", f"mean/{m}",
       "{:.2f}") for m in ("psnr", "psnr_flare")],
    *[("docs/history/gnfr.md", f"pretrain_zero_shot_{scene}_w{step}.json", f"rows/0/{m}",
       "{:.2f}" if m == "psnr" else "{:.3f}")
      for step in (65250,) for scene in ("sceaux", "et") for m in ("psnr", "ssim")],
    *[("docs/history/gnfr.md", f"pretrain_zero_shot_{scene}_w60000.json", f"rows/0/{m}",
       "{:.2f}" if m == "psnr" else "{:.3f}")
      for scene in ("sceaux", "et") for m in ("psnr", "ssim")],
    *[("docs/history/gnfr.md", f"pretrain_zero_shot_{scene}_w42250.json", f"rows/0/{m}",
       "{:.2f}" if m == "psnr" else "{:.3f}")
      for scene in ("sceaux", "et") for m in ("psnr", "ssim")],
    *[("docs/history/fmg.md", f"mask_downstream_dev_J{f}.json", f"rows/{i}/{m}",
       "{:.4f}" if m == "ssim" else "{:.2f}")
      for f in ("", "_cuts") for i in range(6) for m in ("psnr", "psnr_flare", "ssim")],
    *[("docs/history/fmg.md", f"fmg_fair_{f}.json", f"methods/gnfr/{part}/{m}",
       "{:.4f}" if (part, m) == ("inputs", "ssim") else "{:.3f}" if m == "ssim" else "{:.2f}")
      for f in ("sceaux_shipped", "sceaux_J", "et_shipped", "et_J", "lund_shipped", "lund_J",
                "sceaux_J_cut0.95", "et_J_cut0.95")
      for part, m in (("inputs", "psnr"), ("inputs", "psnr_flare"), ("inputs", "ssim"),
                      ("heldout", "psnr"), ("heldout", "ssim"))],
    *[("docs/history/fmg.md", "mask_time_cpu_J.json", f"rows/{i}/median_s_per_view", "{:.3f}")
      for i in range(2)],
    *[("docs/history/gnfr.md", "finetune_ab_paper_init11000_dev_et.json", f"{row}/{m}",
       "{:.3f}" if m.endswith("ssim") else "{:.2f}")
      for row in ("base", "init-gnfr_paper")
      for m in ("heldout_psnr", "heldout_ssim", "inputs_psnr", "flare_region_psnr")],
    *[("docs/history/fmg.md", "fmg_dev_per_kind_H_rays.json", f"kinds/{kind}/weights/IoU_flare",
       "{:.3f}") for kind in ("starburst", "ghosts", "streaks", "glare", "scatter")],
    *[("docs/history/fmg.md", "mask_dev_scenes_H.json", f"rows/{i}/flare_iou", "{:.3f}")
      for i in (2, 3, 6, 7)],
    *[("docs/history/fmg.md", "fmg_dev_per_kind_I_rays.json", f"kinds/{kind}/weights/IoU_flare",
       "{:.3f}") for kind in ("starburst", "ghosts", "streaks", "glare", "scatter")],
    *[("docs/history/fmg.md", "mask_dev_scenes_I.json", f"rows/{i}/flare_iou", "{:.3f}")
      for i in (2, 3, 6, 7)],
    *[("docs/history/fmg.md", "mask_downstream_dev_cuts.json", f"rows/{i}/{m}",
       "{:.4f}" if m == "ssim" else "{:.2f}")
      for i in range(6) for m in ("psnr", "psnr_flare", "ssim")],
    *[("docs/history/fmg.md", "fmg_dev_per_kind_shipped_cut075_rays.json",
       f"kinds/{kind}/weights/IoU_flare", "{:.3f}")
      for kind in ("starburst", "ghosts", "streaks", "glare", "scatter")],
    *[("docs/history/fill.md", f"depth_min_blob_inputs_fresh_{s}_s12.json", f"rows/{row}/{m}",
       "{:.4f}" if m == "ssim" else "{:.2f}") for s in ("sceaux", "et")
      for row in ("hybrid_guided_support2", "hybrid_depth_min_blob_0.0005")
      for m in ("psnr_flare", "psnr", "ssim")],
    *[("docs/history/fill.md", f"depth_min_blob_inputs_test_{s}.json", f"rows/{row}/{m}",
       "{:.4f}" if m == "ssim" else "{:.2f}") for s in ("kermit_synth", "cyprus_truth")
      for row in ("hybrid_depth_min_blob_0", "hybrid_guided_support2")
      for m in ("psnr_flare", "psnr", "ssim")],
    *[("docs/history/fill.md", f"depth_min_blob_inputs_dev_{s}_{a}.json",
       f"rows/hybrid_guided_support2/{m}", "{:.4f}" if m == "ssim" else "{:.2f}")
      for s in ("sceaux", "et", "lund") for a in ("0", "0.0005", "0.002")
      for m in ("psnr_flare", "psnr", "ssim")],
    *[("docs/history/fill.md", f"depth_min_blob_loo_dev_{s}_{a}.json", m,
       "{:.3f}" if m == "ssim" else "{:.2f}")
      for s in ("sceaux", "et", "lund") for a in ("0", "0.0005", "0.002")
      for m in ("psnr", "ssim")],
    *[("docs/history/fmg.md", f"fmg_dev_per_kind_shipped_cut075_rays{tag}_s14.json",
       f"kinds/{kind}/weights/IoU_flare", "{:.3f}") for tag in ("", "_flip")
      for kind in ("starburst", "ghosts", "streaks", "glare", "scatter")],
    *[("docs/history/fmg.md", "mask_downstream_dev_H.json", f"rows/{i}/{m}",
       "{:.4f}" if m == "ssim" else "{:.2f}")
      for i in range(4) for m in ("psnr", "psnr_flare", "ssim")],
    *[("docs/history/fill.md", f"novel_{split}_close_holes_dev_{scene}_{f}.json", m,
       "{:.3f}" if m == "ssim" else "{:.2f}")
      for split in ("loo", "heldout") for scene in ("sceaux", "et")
      for f in ("0", "0.004", "0.008", "0.016") for m in ("psnr", "ssim")],
    *[("docs/history/fill.md", f"fill_photo_fallback_dev_{draw}.json", f"rows/{row}/{m}",
       "{:.4f}" if m == "ssim" else "{:.2f}")
      for draw in ("sceaux", "et", "lund", "sceaux_s12", "et_s12")
      for row in ("hybrid_guided_support2", "hybrid_photo_fallback_2")
      for m in ("psnr_flare", "psnr", "ssim")],
    *[("docs/history/fill.md", f"fill_photo_fallback_test_{scene}.json", f"rows/{row}/{m}",
       "{:.3f}")
      for scene in ("kermit_synth", "cyprus_truth")
      for row in ("hybrid_photo_fallback_0", "hybrid_photo_fallback_2")
      for m in ("psnr_flare", "psnr")],
    *[("docs/history/fill.md", "sample_oneshot_cpu_s15_fallback.json", f"mean/{m}", "{:.2f}")
      for m in ("psnr_flare", "psnr")],
    *[("docs/history/fill.md", f"depth_min_margin_inputs_dev_{draw}_{mm}.json",
       "rows/hybrid_guided_support2/psnr_flare", "{:.3f}")
      for draw in ("sceaux", "et", "lund", "sceaux_s12", "et_s12") for mm in ("0.03", "0.1")],
    *[("docs/history/fill.md", f"depth_min_margin_heldout_dev_{draw}_{mm}.json", m,
       "{:.3f}" if m == "ssim" else "{:.2f}")
      for draw in ("sceaux", "et", "lund", "sceaux_s12", "et_s12") for mm in ("0.03", "0.1")
      for m in ("psnr", "ssim")],
    *[("docs/history/fill.md", f"novel_heldout_agree_window_fresh_{draw}_{n}.json", m,
       "{:.3f}" if m == "ssim" else "{:.2f}")
      for draw in ("sceaux_s14", "et_s14", "lund_s1") for n in (1, 5) for m in ("psnr", "ssim")],
    *[("docs/history/fill.md", f"fill_agree_window_dev_{draw}.json", f"rows/{row}/psnr_flare",
       "{:.3f}")
      for draw in ("sceaux", "et", "lund", "sceaux_s12", "et_s12")
      for row in ("hybrid_guided_support2", "hybrid_agree_window_3", "hybrid_agree_window_5")],
    *[("docs/history/fill.md", f"novel_heldout_agree_window_dev_{draw}_{n}.json", m,
       "{:.3f}" if m == "ssim" else "{:.2f}")
      for draw in ("sceaux", "et", "lund", "sceaux_s12", "et_s12") for n in (3, 5)
      for m in ("psnr", "ssim")],
    *[("docs/history/fill.md", f"novel_heldout_photo_fallback_dev_{draw}_2.json", m,
       "{:.3f}" if m == "ssim" else "{:.2f}")
      for draw in ("sceaux", "et", "lund", "sceaux_s12", "et_s12") for m in ("psnr", "ssim")],
    *[("docs/history/fill.md", f"novel_heldout_sharp_holes_dev_{draw}_{r}.json", m,
       "{:.3f}" if m == "ssim" else "{:.2f}")
      for draw in ("sceaux", "et", "lund", "sceaux_s12", "et_s12")
      for r in ("0", "0.004", "0.008", "0.016") for m in ("psnr", "ssim")],
    *[("docs/history/fill.md", f"novel_{split}_sharp_holes_dev_{scene}_{r}.json", m,
       "{:.3f}" if m == "ssim" else "{:.2f}")
      for split, scenes in (("nontarget", ("sceaux", "lund")),
                            ("loo", ("sceaux", "et", "lund")))
      for scene in scenes for r in ("0", "0.008") for m in ("psnr", "ssim")],
    *[("docs/history/fill.md", f"novel_{split}_s13_dev_{scene}_{v}.json", m,
       "{:.3f}" if m == "ssim" else "{:.2f}")
      for split in ("loo", "heldout") for scene in ("sceaux", "et")
      for v in ("base", "beyond_4", "vote_0.05", "vote_0.1") for m in ("psnr", "ssim")],
    *[("docs/history/fill.md", f"fill_layer_local_dev_{scene}.json", f"rows/{row}/{m}",
       "{:.4f}" if m == "ssim" else "{:.2f}")
      for scene in ("sceaux", "et")
      for row in ("hybrid_guided_support2", "hybrid_layer_local_0.005",
                  "hybrid_layer_local_0.01", "hybrid_layer_local_0.02")
      for m in ("psnr_flare", "psnr", "ssim")],
    *[("docs/history/fill.md", f"fill_min_region_dev_{scene}.json", f"rows/{row}/psnr_flare",
       "{:.2f}")
      for scene in ("sceaux", "et")
      for row in ("hybrid_guided_support2", "hybrid_min_region_0.0001",
                  "hybrid_min_region_0.0004", "hybrid_min_region_0.001")],
    *[("docs/history/fill.md", f"fill_clipped_dev_{scene}.json", f"rows/{row}/{m}",
       "{:.4f}" if m == "ssim" else "{:.2f}")
      for scene in ("sceaux", "et") for row in ("hybrid_guided_support2", "hybrid_clipped_all")
      for m in ("psnr_flare", "psnr", "ssim")],
    *[("docs/history/fill.md", f"fill_layer_adapt_dev_{scene}.json", f"rows/{row}/{m}",
       "{:.4f}" if m == "ssim" else "{:.2f}")
      for scene in ("sceaux", "et")
      for row in ("hybrid_guided_support2", "hybrid_layer_adapt_0.5", "hybrid_layer_adapt_1.0")
      for m in ("psnr_flare", "psnr", "ssim")],
    *[("docs/history/fill.md", f"fill_layer_adapt_nc_dev_{scene}.json",
       f"rows/hybrid_layer_adapt_0.5_no_cores/{m}", "{:.4f}" if m == "ssim" else "{:.2f}")
      for scene in ("sceaux", "et") for m in ("psnr_flare", "psnr", "ssim")],
    *[("docs/history/fill.md", f"fill_layer_combo_dev_{scene}.json", f"rows/{row}/{m}",
       "{:.4f}" if m == "ssim" else "{:.2f}")
      for scene in ("sceaux", "et", "lund")
      for row in ("hybrid_guided_support2", "hybrid_clipped_all_adapt_0.5_no_cores")
      for m in ("psnr_flare", "psnr", "ssim")],
    *[("docs/history/fill.md", "fill_layer_combo_dev_lund.json", f"rows/{row}/{m}",
       "{:.4f}" if m == "ssim" else "{:.2f}")
      for row in ("hybrid_clipped_all", "hybrid_layer_adapt_0.5", "hybrid_layer_local_0.02")
      for m in ("psnr_flare", "psnr", "ssim")],
    *[("docs/history/fill.md", f"fill_layer_bias_adapt_dev_{scene}.json",
       f"rows/hybrid_layer_adapt_0.5_bias_0.05/{m}", "{:.4f}" if m == "ssim" else "{:.2f}")
      for scene in ("sceaux", "et") for m in ("psnr_flare", "psnr", "ssim")],
    *[("docs/history/fill.md", f"fill_beyond_dev_{scene}.json", f"rows/{row}/{m}",
       "{:.4f}" if m == "ssim" else "{:.2f}")
      for scene in ("sceaux", "et") for row in ("hybrid_guided_support2", "hybrid_beyond_4")
      for m in ("psnr_flare", "psnr", "ssim")],
    *[("docs/history/fill.md", f"fill_layer_bias_dev_{scene}.json", f"rows/{row}/{m}",
       "{:.4f}" if m == "ssim" else "{:.2f}")
      for scene in ("sceaux", "et") for row in ("hybrid_guided_support2", "hybrid_layer_bias_0.25")
      for m in ("psnr_flare", "psnr", "ssim")],
]


@pytest.mark.parametrize("page, file, path, fmt", CHECKS,
                         ids=[f"{c[0]}:{c[1]}:{c[2]}" for c in CHECKS])
def test_page_quotes_its_result_file(page, file, path, fmt):
    assert_quoted(page, file, path, fmt)

