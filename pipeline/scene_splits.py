"""Which real scenes train and which are kept out.

Every training run (FMG composites, GN-FR pretraining) keeps ``HELDOUT_SCENES`` out, and
evaluation scores only those, so no reported number is measured on a scene a shipped model
has seen. ``cyprus`` is also the source of the shipped sample scene.
"""

from __future__ import annotations

TEST_SCENES: tuple[str, ...] = ("fern", "kermit", "cyprus")
"""Test scenes of ../shared/data/scenes: never trained on, never used for a choice (cuts,
presets, which weights ship, post-processing); only reported. fern is LLFF's yardstick."""

HELDOUT_SCENES: tuple[str, ...] = TEST_SCENES
"""Scenes every training run leaves out (the test scenes); evaluation scores these."""

DEV_SCENES: tuple[str, ...] = ("sceaux_castle", "et")
"""Development scenes: where choices are made and measured before they are kept. They are
also pretraining scenes (the shipped GN-FR weights saw them), so a network's numbers on
them are optimistic; a choice between two settings of the same network is still fair."""

FMG_DEV_SCENES: tuple[str, ...] = ("lund",)
"""Scenes the FMG never trains on and makes its choices on (validation during training, which
run ships, the cut): composites on their photos are the FMG's development set. GN-FR may still
pretrain on them (the FMG and GN-FR are separate networks)."""

TRAIN_SCENES: tuple[str, ...] = ("et", "sceaux_castle", "sacre_coeur", "buddha", "temple",
                                 "fox", "dino", "maryrose", "tumbler", "lund")
"""Scenes training may use (dino cannot be posed; it only serves as FMG background; lund
ships no poses and is posed by the pipeline)."""
