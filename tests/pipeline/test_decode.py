"""Decode stage: real camera raw files, JPEG orientation, RAW+JPEG pairs, resume."""

from __future__ import annotations

import shutil
import struct
from pathlib import Path

import cv2
import numpy as np
import pytest

from pipeline import decode
from pipeline.workspace import Workspace, digest_paths
from tests.conftest import shared
from workflows.cli import main

RAW_FILES = ["Blackmagic.dng", "RAW_KODAK_DC50.KDC", "canon_eos_6d.dng",
             "Nikon_uncompressed.nef"]


@pytest.fixture(scope="module")
def raw_ws(tmp_path_factory) -> Workspace:
    """The four real raw files of shared/data/raw decoded at --max-size 512."""
    src = shared("raw")
    out = tmp_path_factory.mktemp("raw") / "raw.deflare"
    assert main(["decode", str(src), "--out", str(out), "--max-size", "512"]) == 0
    return Workspace.open(out)


def test_raw_sizes_and_orientation(raw_ws):
    import rawpy

    for name in RAW_FILES:
        stem = Path(name).stem
        png = cv2.imread(str(raw_ws.decoded / f"{stem}.png"), cv2.IMREAD_UNCHANGED)
        lin = cv2.imread(str(raw_ws.linear / f"{stem}.tiff"), cv2.IMREAD_UNCHANGED)
        assert png.dtype == np.uint8 and png.ndim == 3 and png.shape[2] == 3
        assert lin.dtype == np.uint16 and lin.shape == png.shape
        with rawpy.imread(str(raw_ws.photos_dir / name)) as raw:
            w, h = raw.sizes.width, raw.sizes.height
            if raw.sizes.flip in (5, 6):  # portrait: LibRaw swaps the axes
                w, h = h, w
        assert max(png.shape[:2]) == min(512, max(w, h))
        assert abs(png.shape[1] / png.shape[0] - w / h) < 0.02 * w / h


def test_raw_values_sane(raw_ws):
    for name in RAW_FILES:
        stem = Path(name).stem
        png = cv2.imread(str(raw_ws.decoded / f"{stem}.png"))
        lin = cv2.imread(str(raw_ws.linear / f"{stem}.tiff"), cv2.IMREAD_UNCHANGED)
        assert 15 < png.mean() < 240, f"{name}: decoded image black or blown out"
        assert png.std() > 10, f"{name}: decoded image flat"
        assert (png == 255).mean() < 0.2, f"{name}: highlights clipped"
        assert lin.mean() > 500, f"{name}: linear image black"
        means = png.reshape(-1, 3).mean(0)
        assert means.max() / means.min() < 2.0, f"{name}: white balance off ({means})"
        lmeans = lin.reshape(-1, 3).astype(float).mean(0)
        assert lmeans.max() / lmeans.min() < 2.5, f"{name}: linear white balance off"
        # linear and sRGB agree in brightness order (same pixels, monotone encoding)
        g_lin = lin[..., 1].astype(float).ravel()
        g_png = png[..., 1].astype(float).ravel()
        assert np.corrcoef(g_lin, g_png)[0, 1] > 0.7, name


def test_raw_manifest(raw_ws):
    rec = raw_ws.stage_record("decode")
    assert rec["status"] == "complete"
    assert rec["sources"] == {Path(n).stem: n for n in RAW_FILES}
    assert sorted(rec["raw"]) == sorted(Path(n).stem for n in RAW_FILES)


def test_srgb_encode_properties():
    from pipeline.colour import linear_to_srgb, srgb_to_linear

    x = np.linspace(0, 1, 1001)
    y = linear_to_srgb(x, exact=True)  # what decode encodes its 8-bit PNGs with
    assert y.dtype == np.float64 and y[0] == 0 and abs(y[-1] - 1) < 1e-9
    assert np.all(np.diff(y) > 0)
    assert abs(linear_to_srgb(np.array([0.18]), exact=True)[0] - 0.4614) < 1e-3  # mid grey
    np.testing.assert_allclose(srgb_to_linear(y, exact=True), x, atol=1e-12)
    np.testing.assert_allclose(linear_to_srgb(x), y, atol=2e-6)  # the fast float32 path
    assert decode.target_size(4000, 3000, 1008) == (1008, 756)
    assert decode.target_size(400, 300, 1008) == (400, 300)  # never upscaled
    assert decode.target_size(400, 300, 0) == (400, 300)


def _with_exif_orientation(jpeg: bytes, orientation: int) -> bytes:
    """The JPEG with an APP1 EXIF segment holding only the Orientation tag."""
    tiff = b"MM\x00\x2a" + struct.pack(">I", 8) + struct.pack(">H", 1)
    tiff += struct.pack(">HHIHH", 0x0112, 3, 1, orientation, 0) + struct.pack(">I", 0)
    payload = b"Exif\x00\x00" + tiff
    app1 = b"\xff\xe1" + struct.pack(">H", len(payload) + 2) + payload
    return jpeg[:2] + app1 + jpeg[2:]


def test_jpeg_orientation_raw_pair_and_unchanged_folder(tmp_path, capsys):
    kermit = shared("scenes", "kermit")
    photos = tmp_path / "photos"
    photos.mkdir()
    for i in range(3):
        shutil.copy(kermit / f"kermit00{i}.jpg", photos)
    data = (kermit / "kermit003.jpg").read_bytes()
    (photos / "rotated.jpg").write_bytes(_with_exif_orientation(data, 6))
    shutil.copy(shared("raw", "canon_eos_6d.dng"), photos / "pair.dng")
    shutil.copy(kermit / "kermit004.jpg", photos / "pair.jpg")
    before = digest_paths([photos])
    assert main(["decode", str(photos), "--max-size", "320"]) == 0
    assert digest_paths([photos]) == before
    ws = Workspace.open(tmp_path / "photos.deflare")  # default --out: beside the folder
    rot = cv2.imread(str(ws.decoded / "rotated.png"))
    assert rot.shape[:2] == (320, 240)  # 640x480 rotated by 90 degrees
    ref = cv2.resize(cv2.imread(str(kermit / "kermit003.jpg")), (320, 240),
                     interpolation=cv2.INTER_AREA)
    turned = cv2.rotate(ref, cv2.ROTATE_90_CLOCKWISE)
    assert np.abs(rot.astype(int) - turned).mean() < 3
    assert (ws.linear / "pair.tiff").exists()  # the raw of the RAW+JPEG pair was kept
    assert cv2.imread(str(ws.decoded / "pair.png")).shape[:2] == (213, 320)
    assert ws.stage_record("decode")["sources"]["pair"] == "pair.dng"
    err = capsys.readouterr().err
    assert "pair.dng, pair.jpg share the stem 'pair'" in err


def _crash_after(count: int, calls: list[str], monkeypatch):
    """Make decode write ``count`` photos (their stems into ``calls``), then crash."""
    real = decode._decode_file

    def failing(photo, cfg, png, tiff):
        if len(calls) == count:
            raise RuntimeError("simulated crash")
        calls.append(photo.stem)
        real(photo, cfg, png, tiff)

    monkeypatch.setattr(decode, "_decode_file", failing)
    return real


def test_resume_after_interrupt(tmp_path, monkeypatch):
    kermit = shared("scenes", "kermit")
    calls: list[str] = []
    real = _crash_after(3, calls, monkeypatch)
    out = tmp_path / "ws"
    with pytest.raises(RuntimeError):
        decode.run(decode.DecodeConfig(max_size=200), kermit, out)
    ws = Workspace.open(out)
    assert ws.stage_record("decode")["status"] == "running"
    assert sorted(p.stem for p in ws.decoded.iterdir()) == calls  # no half-written file
    first = {s: (ws.decoded / f"{s}.png").stat().st_mtime_ns for s in calls}
    monkeypatch.setattr(decode, "_decode_file", lambda *a: (calls.append(a[0].stem), real(*a)))
    decode.run(decode.DecodeConfig(max_size=200), kermit, out)
    assert len(calls) == 11  # the 3 finished files were not decoded again
    assert {s: (ws.decoded / f"{s}.png").stat().st_mtime_ns for s in first} == first
    assert ws.stage_record("decode")["status"] == "complete"
    assert len(list(ws.decoded.glob("*.png"))) == 11
    decode.run(decode.DecodeConfig(max_size=200), kermit, out)  # up to date: no work
    assert len(calls) == 11
    decode.run(decode.DecodeConfig(max_size=160), kermit, out)  # new parameters: all again
    assert len(calls) == 22
    assert max(cv2.imread(str(ws.decoded / "kermit000.png")).shape) == 160


def test_a_decode_at_new_settings_stopped_midway_never_keeps_the_earlier_images(tmp_path,
                                                                                  monkeypatch):
    """A finished decode at one size, then one at another stopped after 3 photos: the next
    attempt keeps those 3 and decodes the rest again, rather than taking the earlier run's
    images (of the old size) as the interrupted run's."""
    kermit = shared("scenes", "kermit")
    out = tmp_path / "ws"
    decode.run(decode.DecodeConfig(max_size=200), kermit, out)
    calls: list[str] = []
    real = _crash_after(3, calls, monkeypatch)
    with pytest.raises(RuntimeError):
        decode.run(decode.DecodeConfig(max_size=160), kermit, out)
    monkeypatch.setattr(decode, "_decode_file", lambda *a: (calls.append(a[0].stem), real(*a)))
    decode.run(decode.DecodeConfig(max_size=160), kermit, out)
    assert len(calls) == 11 and len(set(calls)) == 11  # the 3 kept, the other 8 again
    ws = Workspace.open(out)
    sizes = {max(cv2.imread(str(p)).shape) for p in ws.decoded.glob("*.png")}
    assert sizes == {160} and len(list(ws.decoded.glob("*.png"))) == 11


def test_without_copies_compares_whole_files_of_one_size(tmp_path, capsys):
    """Files of one size (one camera's uncompressed raws) are copies only when every byte is
    the same: two that share their first MiB and differ after it both stay; a true copy
    goes, named in one warning; empty files are left to decoding."""
    from pipeline.decode import Photo, without_copies

    head = bytes(range(256)) * 4096  # 1 MiB
    files = {"a.dng": head + b"A" * 1000, "b.dng": head + b"B" * 1000,
             "c.dng": head + b"A" * 1000, "e1.jpg": b"", "e2.jpg": b""}
    photos = []
    for name, data in files.items():
        (tmp_path / name).write_bytes(data)
        photos.append(Photo(tmp_path / name, name.split(".")[0], name.endswith(".dng")))
    kept = [p.stem for p in without_copies(photos)]
    assert kept == ["a", "b", "e1", "e2"]
    err = capsys.readouterr().err
    assert err.count("same file") == 1 and "c.dng is the same file as a.dng" in err


def test_unusual_formats_decode_to_the_same_pixels(tmp_path, capsys):
    """16-bit RGBA PNG, a TIFF with an extra channel, a float TIFF, greyscale JPEG and WebP
    decode to the picture they hold; an empty file is named as empty in one line, and
    OpenCV's own warnings (the TIFF's extra samples) stay out of the user's terminal."""
    rng = np.random.default_rng(0)
    img = cv2.resize(rng.integers(0, 256, (12, 16, 3), dtype=np.uint8), (160, 120),
                     interpolation=cv2.INTER_CUBIC)
    photos = tmp_path / "photos"
    photos.mkdir()
    alpha = np.full(img.shape[:2], 255, np.uint8)
    cv2.imwrite(str(photos / "rgba16.png"), np.dstack([img, alpha]).astype(np.uint16) * 257)
    cv2.imwrite(str(photos / "four.tiff"), np.dstack([img, alpha // 2]))
    cv2.imwrite(str(photos / "float.tiff"), img.astype(np.float32) / 255)
    cv2.imwrite(str(photos / "lossless.webp"), img, [cv2.IMWRITE_WEBP_QUALITY, 101])
    cv2.imwrite(str(photos / "grey.jpg"), cv2.cvtColor(img, cv2.COLOR_BGR2GRAY),
                [cv2.IMWRITE_JPEG_QUALITY, 100])
    (photos / "empty.jpg").write_bytes(b"")
    assert main(["decode", str(photos), "--out", str(tmp_path / "ws")]) == 0
    dec = tmp_path / "ws" / "decoded"
    for stem in ("rgba16", "four", "float", "lossless"):
        assert np.abs(cv2.imread(str(dec / f"{stem}.png")).astype(int) - img).max() <= 1, stem
    grey = cv2.imread(str(dec / "grey.png")).astype(int)
    assert np.abs(grey - cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)[..., None]).mean() < 2
    assert not (dec / "empty.png").exists()
    err = capsys.readouterr().err
    assert [ln for ln in err.splitlines() if "empty.jpg" in ln] == [
        "warning: skipping empty.jpg: empty file (0 bytes); replace or remove the file"]
    assert "WARN" not in err and "TIFF" not in err
