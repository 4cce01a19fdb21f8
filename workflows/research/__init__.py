"""Research tools apart from the product: evaluation, pretraining, FMG training, benchmarks.

``eval`` and ``eval_llff`` score GN-FR against ablations and baselines, ``pretrain`` and
``pretrain_scenes`` train the shipped generalizable weights, ``fmg_train`` trains and scores
the flare mask network and ``bench`` measures speed. The product (``deflare-scene PHOTOS``
and the stage commands) never imports this package.
"""

from workflows.threads import apply_thread_policy

apply_thread_policy()  # before any research module imports torch (workflows/threads.py)
