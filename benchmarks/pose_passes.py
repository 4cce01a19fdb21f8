"""Images registered and pose accuracy of each mapping pass of the pose stage, on real scenes.

For each ``NAME=FOLDER`` this decodes the photos at ``--max-size`` into WORK/NAME.ws, runs
the pose stage there once (its features and matches stay in WORK/NAME.ws/colmap), then maps
the same database with each pass of ``pipeline.pose.PASSES`` (default, relaxed, loose) and
scores each pass's largest model: images registered, and against the scene's reference
poses where it has some (temple and dino: Middlebury's ground truth; buddha: its projection
matrices; fox: instant-ngp's transforms.json; an LLFF folder: poses_bounds.npy), the
rotation and camera-centre errors after aligning the model to the reference by the
rotations' mean and a least-squares scale and shift (centre errors as fractions of the
reference cameras' extent). It reports which pass the stage's rule picks with the loose
pass (``pipeline.pose.next_pass``) and without it, so a change of the passes is judged on
the same matches. The thread count is the process's (set OMP_NUM_THREADS; COLMAP gets one
thread and seed 0, as `benchmarks/build_dev_scenes.sh` poses).

    python benchmarks/pose_passes.py NAME=FOLDER [NAME=FOLDER ...] --work DIR \
        [--max-size 1008] --out J
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def reference_poses(folder: Path) -> tuple[str, dict[str, np.ndarray]] | None:
    """(kind, {photo stem: c2w [4, 4] OpenCV}) of a scene folder that carries poses."""
    from pipeline.images import list_photos
    from pipeline.training_scenes import llff_to_opencv, read_poses_bounds
    from workflows.research import pretrain_scenes as ps

    scene = folder.parent if folder.name in ("images", "images_4", "images_8") else folder
    if list(scene.glob("*_par.txt")):
        return "middlebury", {Path(r).stem: c for r, _, c in ps.middlebury(scene, scene.name)}
    if (scene / "projections").is_dir():
        return "projections", {Path(r).stem: c for r, _, c in ps.buddha(scene)}
    if (scene / "transforms.json").is_file():
        return "transforms.json", {Path(r).stem: c for r, _, c in ps.fox(scene, every=1)}
    if (scene / "poses_bounds.npy").is_file():
        pb = read_poses_bounds(scene / "poses_bounds.npy")
        files = list_photos(folder)
        if len(files) == len(pb):
            c2w = llff_to_opencv(pb[:, :15].reshape(-1, 3, 5))
            return "poses_bounds.npy", {f.stem: c for f, c in zip(files, c2w, strict=True)}
    return None


def model_poses(rec) -> dict[str, np.ndarray]:
    """{image stem: c2w [4, 4] OpenCV} of a pycolmap reconstruction's registered images."""
    from pipeline import colmap_io

    return {Path(im.name).stem: colmap_io.cam_to_world(im)
            for im in colmap_io.registered_images(rec)} if rec is not None else {}


def pose_errors(est: dict[str, np.ndarray], ref: dict[str, np.ndarray]) -> dict | None:
    """Rotation errors (degrees) and centre errors (fraction of the reference cameras'
    extent) of ``est`` against ``ref`` on their common views, after a similarity: the
    rotation is the chordal mean of the per-view rotations between them (centres alone
    leave a walk's roll free), the scale and shift a least-squares fit of the centres."""
    common = sorted(set(est) & set(ref))
    if len(common) < 3:
        return None
    per = [ref[n][:3, :3] @ est[n][:3, :3].T for n in common]  # world rotation, per view
    U, _, Vt = np.linalg.svd(sum(per))
    W = U @ np.diag([1, 1, np.sign(np.linalg.det(U @ Vt))]) @ Vt
    rot = [np.degrees(np.arccos(np.clip((np.trace(W.T @ P) - 1) / 2, -1, 1))) for P in per]
    a = np.array([ref[n][:3, 3] for n in common])
    b = np.array([W @ est[n][:3, 3] for n in common])
    a0, b0 = a - a.mean(0), b - b.mean(0)
    s = float((a0 * b0).sum() / max((b0 * b0).sum(), 1e-12))
    err = np.linalg.norm(s * b0 - a0, axis=1) / max(np.linalg.norm(a0, axis=1).max(), 1e-12)
    return {"views": len(common), "rotation_deg_median": round(float(np.median(rot)), 3),
            "rotation_deg_max": round(float(max(rot)), 3),
            "centre_median": round(float(np.median(err)), 4),
            "centre_max": round(float(err.max()), 4)}


def chosen_pass(rows: dict, n: int, loose: bool) -> str:
    """The pass the stage keeps (``pipeline.pose.run_passes``), from every pass's
    registered count."""
    from pipeline.pose import PoseConfig, run_passes

    return run_passes(PoseConfig(loose_pass=loose), n, lambda init: rows[init]["registered"],
                      say=lambda _: None)


def scene_rows(name: str, folder: Path, work: Path, max_size: int) -> dict:
    """Decode and pose ``folder`` into WORK/NAME.ws, then map it with every pass."""
    import shutil

    from pipeline import colmap_io, pose
    from pipeline.workspace import Workspace
    from workflows.cli import main as cli

    ws_path = work / f"{name}.ws"
    if cli(["decode", str(folder), "--out", str(ws_path), "--max-size", str(max_size)]) not in (
            0, None):
        raise SystemExit(2)  # decode said why, in one line
    # the stage may refuse a scene (too few registered: dino); its matches are kept
    stage = cli(["pose", str(ws_path), "--threads", "1", "--seed", "0", "--no-loose-pass"])
    ws = Workspace.open(ws_path)
    if not ws.colmap_db.is_file():
        print(f"error: pose wrote no database in {ws_path}: see the lines above",
              file=sys.stderr)
        raise SystemExit(2)
    n = len(list(ws.decoded.glob("*.png")))
    ref = reference_poses(folder)
    cfg = pose.PoseConfig(num_threads=1, seed=0)
    rows, poses = {}, {}
    for init in pose.PASSES:
        out = work / f"{name}.passes" / init
        shutil.rmtree(out, ignore_errors=True)
        out.mkdir(parents=True)
        colmap_io.import_pycolmap().set_random_seed(0)
        with pose._ColmapLog(False):
            recs = pose._map(cfg, ws.colmap_db, ws.decoded, out, n, init)
        sizes = sorted((r.num_reg_images() for r in recs.values()), reverse=True)
        best = colmap_io.largest_model(recs)
        poses[init] = model_poses(best)
        rows[init] = {"registered": sizes[0] if sizes else 0, "models": sizes,
                      "reprojection_px": round(float(best.compute_mean_reprojection_error()), 3)
                      if best is not None else None,
                      "errors": pose_errors(poses[init], ref[1]) if ref else None,
                      "against_default": None if init == "default"
                      else pose_errors(poses[init], poses["default"]),
                      "stems": sorted(poses[init])}
    without, with_loose = chosen_pass(rows, n, False), chosen_pass(rows, n, True)
    return {"folder": str(folder), "images": n, "reference": ref[0] if ref else None,
            "stage_without_loose": "passed" if stage in (0, None) else "refused",
            "passes": rows, "chosen_without_loose": without, "chosen_with_loose": with_loose,
            # the model kept with the loose pass against the one kept without it, on their
            # common views (None where the same pass is kept)
            "kept_against_kept_without": None if with_loose == without
            else pose_errors(poses[with_loose], poses[without])}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", nargs="+", help="NAME=FOLDER (a folder of photos)")
    ap.add_argument("--work", type=Path, required=True)
    ap.add_argument("--max-size", type=int, default=1008)
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    from workflows.threads import apply_thread_policy

    apply_thread_policy()
    from pipeline.provenance import write_result

    specs = []
    for spec in a.scenes:
        name, _, folder = spec.partition("=")
        if not folder or not Path(folder).is_dir():
            print(f"error: {spec}: give NAME=FOLDER with FOLDER a folder of photos",
                  file=sys.stderr)
            return 2
        specs.append((name, Path(folder)))
    a.work.mkdir(parents=True, exist_ok=True)
    res = {"max_size": a.max_size, "passes": {}, "scenes": {}}
    from pipeline.pose import PASSES

    res["passes"] = {k: dict(v) for k, v in PASSES.items()}
    for name, folder in specs:
        row = scene_rows(name, folder, a.work, a.max_size)
        res["scenes"][name] = row
        cells = [f"{k} {r['registered']}/{row['images']}" + (
            f" ({r['errors']['rotation_deg_median']:.2f} deg, {r['errors']['centre_median']:.4f})"
            if r["errors"] else "") for k, r in row["passes"].items()]
        print(f"{name}: " + "; ".join(cells) + f"; stage keeps {row['chosen_without_loose']} "
              f"-> {row['chosen_with_loose']}", flush=True)
        if a.out:  # written after every scene: a long run keeps what it reached
            write_result(a.out, res)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
