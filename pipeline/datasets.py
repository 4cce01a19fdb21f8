"""Which real scenes train and which are kept out.

Every training run (FMG composites, GN-FR pretraining) keeps ``HELDOUT_SCENES`` out, and
evaluation scores only those, so no reported number is measured on a scene a shipped model
has seen. ``cyprus`` is also the source of the shipped sample scene.
"""

from __future__ import annotations

HELDOUT_SCENES: tuple[str, ...] = ("kermit", "cyprus")
"""Scenes of ../shared/data/scenes never used for training; evaluation scores these."""

TRAIN_SCENES: tuple[str, ...] = ("et", "sceaux_castle", "sacre_coeur", "buddha", "temple",
                                 "fox", "dino")
"""Scenes training may use (dino cannot be posed; it only serves as FMG background)."""

IMAGE_EXTENSIONS = (".jpg", ".jpeg", ".png", ".tif", ".tiff")
