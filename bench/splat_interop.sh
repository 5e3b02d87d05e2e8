#!/usr/bin/env bash
# Splat PLYs between nerfreg and an independent reader / writer (PyPI's plyfile): the 3DGS layout
# (property names and types), and `reg apply` checked from outside: centres moved by the Sim(3),
# quaternions rotated, log-scales shifted by log(s), opacity and DC colour kept, and each SH degree's
# coefficient norm per channel kept (a rotation mixes coefficients within a degree only).
# Usage: bench/splat_interop.sh [WORK_DIR]   (needs python3 with numpy and plyfile)
# Writes results/splat_interop.md and results/splat_interop.json.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
NERFREG=${NERFREG:-$ROOT/build/nerfreg}
WORK=${1:-$(mktemp -d /tmp/splat_interop.XXXXXX)}
mkdir -p "$WORK"
python3 -c "import numpy, plyfile" || { echo "error: python3: expected numpy and plyfile (pip install numpy plyfile)" >&2; exit 2; }
"$NERFREG" render --procedural 7 --views 30 --size 64 --splats --quiet --out "$WORK/data" --force
# A known similarity: 37 deg about (1, 2, 3), scale 1.7, translation (0.3, -0.2, 0.5).
python3 - "$WORK/T.json" <<'PY'
import json, math, sys
import numpy as np
a = np.array([1.0, 2.0, 3.0]); a /= np.linalg.norm(a); t = math.radians(37)
K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
R = np.eye(3) + math.sin(t) * K + (1 - math.cos(t)) * K @ K
M = np.eye(4); M[:3, :3] = 1.7 * R; M[:3, 3] = [0.3, -0.2, 0.5]
json.dump({"target_from_source": M.tolist()}, open(sys.argv[1], "w"))
PY
# The other direction: plyfile writes a copy with random SH coefficients of degrees 1-3 (45
# f_rest), which nerfreg must read, move and rotate.
python3 - "$WORK/data/splats.ply" "$WORK/sh3.ply" <<'PY'
import sys
import numpy as np
from numpy.lib import recfunctions as rfn
from plyfile import PlyData, PlyElement
v = PlyData.read(sys.argv[1])["vertex"].data
rng = np.random.default_rng(0)
extra = np.zeros(len(v), dtype=[("f_rest_%d" % i, "f4") for i in range(45)])
for i in range(45): extra["f_rest_%d" % i] = rng.normal(0, 0.2, len(v)).astype("f4")
names = list(v.dtype.names)
at = names.index("opacity")  # the INRIA order: ..., f_dc_*, f_rest_*, opacity, scale_*, rot_*
merged = rfn.merge_arrays([v[names[:at]], extra, v[names[at:]]], flatten=True)
PlyData([PlyElement.describe(merged, "vertex")], text=False).write(sys.argv[2])
PY
"$NERFREG" reg apply "$WORK/T.json" "$WORK/sh3.ply" --out "$WORK/moved.ply" --force --quiet
python3 - "$WORK" "$ROOT/results" "$0 $*" <<'PY'
import datetime, json, os, sys
import numpy as np
from plyfile import PlyData
work, out_dir, command = sys.argv[1:4]
a = PlyData.read(os.path.join(work, "sh3.ply"))["vertex"]
b = PlyData.read(os.path.join(work, "moved.ply"))["vertex"]
names = [p.name for p in a.properties]
expected = ["x", "y", "z"] + ["f_dc_%d" % i for i in range(3)] + ["opacity"] + ["scale_%d" % i for i in range(3)] + ["rot_%d" % i for i in range(4)]
rest = sorted([n for n in names if n.startswith("f_rest_")], key=lambda n: int(n.split("_")[2]))
M = np.array(json.load(open(os.path.join(work, "T.json")))["target_from_source"])
s = np.cbrt(np.linalg.det(M[:3, :3])); R = M[:3, :3] / s
def col(v, n): return np.asarray(v[n], dtype=np.float64)
xyz = np.stack([col(a, n) for n in "xyz"], 1); xyz_b = np.stack([col(b, n) for n in "xyz"], 1)
def quat(m):  # rotation matrix -> (w, x, y, z)
    w = np.sqrt(max(1e-12, 1 + np.trace(m))) / 2
    return np.array([w, (m[2, 1] - m[1, 2]) / (4 * w), (m[0, 2] - m[2, 0]) / (4 * w), (m[1, 0] - m[0, 1]) / (4 * w)])
def qmul(p, q):
    w1, x1, y1, z1 = p; w2, x2, y2, z2 = q.T
    return np.stack([w1*w2 - x1*x2 - y1*y2 - z1*z2, w1*x2 + x1*w2 + y1*z2 - z1*y2, w1*y2 - x1*z2 + y1*w2 + z1*x2, w1*z2 + x1*y2 - y1*x2 + z1*w2], 1)
q = np.stack([col(a, "rot_%d" % i) for i in range(4)], 1); q /= np.linalg.norm(q, axis=1, keepdims=True)
qb = np.stack([col(b, "rot_%d" % i) for i in range(4)], 1); qb /= np.linalg.norm(qb, axis=1, keepdims=True)
q_expected = qmul(quat(R), q)
rot_err = np.minimum(np.linalg.norm(qb - q_expected, axis=1), np.linalg.norm(qb + q_expected, axis=1))
checks = {
    "plyfile_reads_both": True,
    "vertices": int(len(a.data)), "vertices_after": int(len(b.data)),
    "layout_3dgs": all(n in names for n in expected) and all(p.val_dtype in ("float32", "f4") for p in a.properties if p.name in expected + rest),
    "sh_rest_coefficients": len(rest),
    "centre_error_max": float(np.abs(xyz_b - (xyz @ (s * R).T + M[:3, 3])).max()),
    "quaternion_error_max": float(rot_err.max()),
    "log_scale_error_max": float(max(np.abs(col(b, "scale_%d" % i) - col(a, "scale_%d" % i) - np.log(s)).max() for i in range(3))),
    "opacity_error_max": float(np.abs(col(b, "opacity") - col(a, "opacity")).max()),
    "dc_error_max": float(max(np.abs(col(b, "f_dc_%d" % i) - col(a, "f_dc_%d" % i)).max() for i in range(3))),
}
if rest:  # per channel, coefficients 3k..3k+? : the INRIA layout stores f_rest channel-major
    n_per = len(rest) // 3
    A = np.stack([col(a, n) for n in rest], 1).reshape(-1, 3, n_per); B = np.stack([col(b, n) for n in rest], 1).reshape(-1, 3, n_per)
    errs, start = [], 0
    for deg in range(1, 4):
        k = 2 * deg + 1
        if start + k > n_per: break
        errs.append(float(np.abs(np.linalg.norm(A[:, :, start:start + k], axis=2) - np.linalg.norm(B[:, :, start:start + k], axis=2)).max()))
        start += k
    checks["sh_degree_norm_error_max"] = errs
    # The colour seen along d before the move is the colour seen along R d after it: 3DGS's own SH
    # evaluation (gaussian-splatting's utils/sh_utils.py eval_sh, degree 3), written out here.
    C0, C1 = 0.28209479177387814, 0.4886025119029199
    C2 = [1.0925484305920792, -1.0925484305920792, 0.31539156525252005, -1.0925484305920792, 0.5462742152960396]
    C3 = [-0.5900435899266435, 2.890611442640554, -0.4570457994644658, 0.3731763325901154, -0.4570457994644658,
          1.445305721320277, -0.5900435899266435]
    def eval_sh(sh, d):  # sh [N, 3, 16], d [3] unit -> [N, 3]
        x, y, z = d; xx, yy, zz, xy, yz, xz = x*x, y*y, z*z, x*y, y*z, x*z
        basis = [C0, -C1*y, C1*z, -C1*x, C2[0]*xy, C2[1]*yz, C2[2]*(2*zz - xx - yy), C2[3]*xz, C2[4]*(xx - yy),
                 C3[0]*y*(3*xx - yy), C3[1]*xy*z, C3[2]*y*(4*zz - xx - yy), C3[3]*z*(2*zz - 3*xx - 3*yy),
                 C3[4]*x*(4*zz - xx - yy), C3[5]*z*(xx - yy), C3[6]*x*(xx - 3*yy)]
        return sh @ np.array(basis)
    def full(v, rest_block):
        dc = np.stack([col(v, "f_dc_%d" % i) for i in range(3)], 1)[:, :, None]
        return np.concatenate([dc, rest_block], 2)
    SA, SB = full(a, A), full(b, B)
    rng = np.random.default_rng(1)
    colour_err, changed = 0.0, float(np.abs(A - B).max())
    for _ in range(16):
        d = rng.normal(size=3); d /= np.linalg.norm(d)
        colour_err = max(colour_err, float(np.abs(eval_sh(SA, d) - eval_sh(SB, R @ d)).max()))
    checks["sh_colour_error_max_over_16_directions"] = colour_err
    checks["sh_coefficients_changed_max"] = changed
ok = checks["layout_3dgs"] and checks["vertices"] == checks["vertices_after"] and checks["centre_error_max"] < 1e-4 and \
     checks["quaternion_error_max"] < 1e-5 and checks["log_scale_error_max"] < 1e-5 and checks["opacity_error_max"] == 0 and \
     checks["dc_error_max"] == 0 and all(e < 1e-5 for e in checks.get("sh_degree_norm_error_max", [])) and \
     checks.get("sh_colour_error_max_over_16_directions", 0) < 1e-5 and checks.get("sh_coefficients_changed_max", 1) > 1e-2
date = datetime.datetime.utcnow().strftime("%Y-%m-%d %H:%M UTC")
from importlib.metadata import version
doc = {"date": date, "command": command, "reader": "plyfile %s (PyPI)" % version("plyfile"), "checks": checks, "passed": bool(ok)}
json.dump(doc, open(os.path.join(out_dir, "splat_interop.json"), "w"), indent=1)
lines = ["# Splat PLYs read by an independent reader", "",
         "%s; command `%s`; reader: %s. Data: `nerfreg render --procedural 7 --views 30 --size 64 --splats` "
         "(surface splats, SH degree 0), given random SH coefficients of degrees 1-3 and written again by plyfile, "
         "then moved by `nerfreg reg apply` with a known Sim(3) (37 deg about (1, 2, 3), scale 1.7) and read back by plyfile." % (date, command, doc["reader"]), "",
         "| check | value |", "|---|---|"]
lines += ["| %s | %s |" % (k, v) for k, v in checks.items()]
lines += ["", "All checks passed." if ok else "**Some checks failed.**", ""]
open(os.path.join(out_dir, "splat_interop.md"), "w").write("\n".join(lines))
print("\n".join(lines))
sys.exit(0 if ok else 1)
PY
