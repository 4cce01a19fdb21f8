"""End-to-end smoke run of the one-shot command on the shipped sample (tiny settings)."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import cv2
import pytest

from pipeline.errors import UserError
from workflows.cli import main
from workflows.oneshot import _stage_configs, apply_overrides

REPO = Path(__file__).resolve().parents[1]
SAMPLE = REPO / "samples" / "cyprus"
TRUTH = REPO / "samples" / "cyprus_truth"


def _tree_digest(folder: Path) -> str:
    h = hashlib.sha256()
    for p in sorted(folder.rglob("*")):
        if p.is_file():
            h.update(p.name.encode() + p.read_bytes())
    return h.hexdigest()


TINY_ARGS = ["--max-size", "200", "--masks", str(TRUTH / "masks_gt"), "--preset", "tiny",
             "--iters", "4", "--frames", "3", "--fps", "6", "--device", "cpu",
             "--set", "render.scale=0.25", "--set", "render.samples=8",
             "--set", "render.chunk=4096", "--set", "pose.num_threads=1"]


def test_one_shot_on_sample_produces_video_and_deflared_photos(tmp_path, capsys):
    before = _tree_digest(SAMPLE)
    ws = tmp_path / "cyprus.deflare"
    assert main([str(SAMPLE), "--out", str(ws), *TINY_ARGS]) == 0
    err = capsys.readouterr().err
    video = ws / "cyprus.mp4"
    assert video.is_file() and str(video) in err.replace("\n", "")
    cap = cv2.VideoCapture(str(video))
    n = int(cap.get(cv2.CAP_PROP_FRAME_COUNT))
    ok, frame = cap.read()
    assert ok and n == 3 and frame.ndim == 3
    stems = sorted(p.stem for p in SAMPLE.glob("*.jpg"))
    deflared = sorted(p.stem for p in (ws / "deflared").glob("*.png"))
    assert deflared == stems
    for s in stems:  # de-flared photos keep the decoded framing and size
        a = cv2.imread(str(ws / "deflared" / f"{s}.png"))
        b = cv2.imread(str(ws / "decoded" / f"{s}.png"))
        assert a.shape == b.shape
    man = json.loads((ws / "manifest.json").read_text())
    for stage in ("decode", "pose", "mask", "select", "finetune", "render:inputs",
                  "render:interpolate", "export"):
        assert man["stages"][stage]["status"] == "complete", stage
    assert _tree_digest(SAMPLE) == before  # the photo folder is only read

    # a second run finds every stage up to date and redoes nothing
    assert main([str(SAMPLE), "--out", str(ws), *TINY_ARGS]) == 0
    man2 = json.loads((ws / "manifest.json").read_text())
    assert all(man2["stages"][s]["started"] == man["stages"][s]["started"]
               for s in man["stages"])


def test_set_overrides_reach_stage_configs():
    st = apply_overrides(_stage_configs(), ["finetune.rays=512", "render.size=320x240",
                                            "mask.masks_dir=/tmp/m", "select.max_flare=0.2",
                                            "finetune.iters=none"])
    assert st["finetune"].rays == 512 and st["finetune"].iters is None
    assert st["render"].size == (320, 240)
    assert str(st["mask"].masks_dir) == "/tmp/m" and st["select"].max_flare == 0.2


@pytest.mark.parametrize("item, msg", [
    ("finetune.nope=1", "has no option 'nope'"),
    ("nostage.x=1", "unknown stage"),
    ("finetune.rays", "use STAGE.FIELD=VALUE"),
    ("finetune.rays=many", "not a valid int"),
])
def test_bad_set_is_a_clear_error(item, msg):
    with pytest.raises(UserError, match=msg):
        apply_overrides(_stage_configs(), [item])
