#!/usr/bin/env python3
"""How well the ground truth explains a model's own observations (issue 42's Castle-simu target).

Every track of a nerfreg (or COLMAP) text model is triangulated twice, with the model's poses and
with the ground-truth poses (the model's pinhole intrinsics both times), each point refined by
Gauss-Newton with the poses held, and the per-observation reprojection errors compared. Where the
truth reprojects the tracks no better than the model's poses do, the tracks do not tell the two
apart, and a rotation error between them is below what those observations determine.

Usage: scripts/castle_truth_reprojection.py MODEL_TXT_DIR REAL_POSES_JSON [SET]
  MODEL_TXT_DIR: a COLMAP text model (cameras.txt with one PINHOLE camera, images.txt);
  REAL_POSES_JSON: bench/real_poses.sh's JSON (its "gt_poses" of SET, default castle).
Needs numpy (bench/real_poses.sh's .bench-venv has it).
"""
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "bench"))
import real_poses as rp  # noqa: E402


def read_model(folder):
    """Pinhole intrinsics, {name: (R, t)} and the tracks [(name, x, y), ...] of a COLMAP text model."""
    poses, cams, _, _ = rp.read_colmap_text(folder)
    model, _, _, params = next(iter(cams.values()))
    if len(cams) != 1 or model != "PINHOLE":
        sys.exit("error: %s/cameras.txt: cameras: expected one PINHOLE camera" % folder)
    # read_colmap_text keeps no observations: each image's second line is its POINTS2D[] (x y id).
    lines = [l for l in open(os.path.join(folder, "images.txt")) if not l.startswith("#")]
    tracks = {}
    for k in range(0, len(lines) - 1, 2):
        name, p = lines[k].split()[9], lines[k + 1].split()
        for i in range(0, len(p), 3):
            if int(p[i + 2]) >= 0:
                tracks.setdefault(int(p[i + 2]), []).append((name, float(p[i]), float(p[i + 1])))
    return tuple(params[:4]), poses, list(tracks.values())


def track_errors(poses, track, intrinsics):
    """Reprojection errors (px) of one track's point, triangulated then refined with poses held."""
    fx, fy, cx, cy = intrinsics
    k = np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1]])
    a = []
    for n, u, v in track:
        p = k @ np.hstack([poses[n][0], poses[n][1][:, None]])
        a += [u * p[2] - p[0], v * p[2] - p[1]]
    x = np.linalg.svd(np.array(a))[2][-1]
    x = x[:3] / x[3]
    for _ in range(10):
        jac, res = [], []
        for n, u, v in track:
            r, t = poses[n]
            xc = r @ x + t
            z = xc[2]
            res += [fx * xc[0] / z + cx - u, fy * xc[1] / z + cy - v]
            jac += [fx * (r[0] / z - xc[0] * r[2] / z**2), fy * (r[1] / z - xc[1] * r[2] / z**2)]
        x = x - np.linalg.lstsq(np.array(jac), np.array(res), rcond=None)[0]
    out = []
    for n, u, v in track:
        xc = poses[n][0] @ x + poses[n][1]
        out.append(np.hypot(fx * xc[0] / xc[2] + cx - u, fy * xc[1] / xc[2] + cy - v))
    return out


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    intrinsics, poses, tracks = read_model(sys.argv[1])
    name = sys.argv[3] if len(sys.argv) > 3 else "castle"
    sets = [s for s in json.load(open(sys.argv[2]))["sets"] if s["name"] == name]
    if not sets:
        sys.exit("error: %s: sets: expected one named %s" % (sys.argv[2], name))
    gt = {n: (np.asarray(v["cam_from_world_R"]), np.asarray(v["cam_from_world_t"])) for n, v in sets[0]["gt_poses"].items()}
    tracks = [t for t in tracks if all(n in gt for n, _, _ in t)]
    c = rp.compare(poses, gt)
    print("%s: %d tracks; the model's poses are %.3f deg (median rotation) from the truth" %
          (sys.argv[1], len(tracks), c["rot_deg_median"]))
    for label, p in (("model's poses", poses), ("truth's poses", gt)):
        e = np.concatenate([track_errors(p, t, intrinsics) for t in tracks])
        print("  %s: %d observations, reprojection error median %.3f, mean %.3f, 90th percentile %.3f px" %
              (label, len(e), np.median(e), e.mean(), np.percentile(e, 90)))


if __name__ == "__main__":
    main()
